"""The root of every error FIDO's library raises."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["FidoError", "StereoGeometryError", "MotionError"]


class FidoError(ModuleError):
    """Base of every error FIDO's library raises (the message says where and what)."""


class StereoGeometryError(FidoError, ValueError):
    """A stereo capture FIDO cannot use: a missing image or calibration, or a pair that is not rectified."""


class MotionError(FidoError):
    """Too few consistent tracked features to estimate the vehicle's motion from."""
