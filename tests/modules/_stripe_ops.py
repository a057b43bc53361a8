"""Stripe operators for the parallel-vision tests (module level: spawned workers import them by name)."""

from __future__ import annotations

import os

import cv2
import numpy as np

__all__ = ["box_sum", "boom", "die_on_second", "squares", "library_threads"]


def box_sum(arrays, k: int, stripe):
    """Sum each pixel's k×k neighbourhood (zeros beyond the image): reads (k − 1) / 2 pixels across a cut."""
    return {"out": cv2.boxFilter(arrays["img"], -1, (k, k), normalize=False, borderType=cv2.BORDER_CONSTANT)}


def boom(arrays, params, stripe):
    """Fail on every stripe but the first."""
    if stripe.index > 0:
        raise ValueError(f"bad pixel in stripe {stripe.index}")
    return {"out": arrays["img"]}


def die_on_second(arrays, params, stripe):
    """End the worker process that gets the second stripe."""
    if stripe.index == 1:
        os._exit(3)
    return {"out": arrays["img"]}


def squares(items, offset):
    """Return each item squared plus `offset`, with the process that did it."""
    return [(i * i + offset, os.getpid()) for i in items]


def library_threads(items, params):
    """Return, per item, this process's pid and the threads its libraries use in one operation (OpenCV, each BLAS)."""
    from threadpoolctl import threadpool_info

    return [(os.getpid(), cv2.getNumThreads(), tuple(sorted(i["num_threads"] for i in threadpool_info()))) for _ in items]
