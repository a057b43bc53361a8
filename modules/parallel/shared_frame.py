"""Frames in shared memory: a frame's arrays laid out in one `multiprocessing.shared_memory` block.

The Warp kept the image resident in cell memory and sent each cell its stripe; here the host
copies a frame's arrays once into a block that every worker process maps, so a stripe is a numpy
view of that block, never a pickled copy. The host owns the block (`SharedFrame`) and reuses it
frame after frame, growing it (under a new name) when a frame needs more room; a worker maps a
block by name (`attach`) and keeps the mapping until the host moves to another block.
"""

from __future__ import annotations

from dataclasses import dataclass
from multiprocessing import shared_memory
from typing import Mapping

import numpy as np

from modules.parallel.errors import ParallelError

__all__ = ["ArrayRef", "SharedFrame", "attach", "view"]

_ALIGN = 64  # [bytes] every array starts on a cache line


@dataclass(frozen=True)
class ArrayRef:
    """Where one array lives in a shared block: byte `offset`, `shape`, `dtype` (numpy's string form)."""

    offset: int
    shape: tuple[int, ...]
    dtype: str

    @property
    def nbytes(self) -> int:
        """Return the array's size [bytes]."""
        return int(np.prod(self.shape, dtype=np.int64)) * np.dtype(self.dtype).itemsize


def view(buf: memoryview, ref: ArrayRef) -> np.ndarray:
    """Return the array `ref` describes as a view of the shared buffer `buf`."""
    return np.ndarray(ref.shape, dtype=np.dtype(ref.dtype), buffer=buf, offset=ref.offset)


class SharedFrame:
    """The host's shared block: `place` lays out a frame's inputs and outputs, `array` views one of them."""

    def __init__(self, nbytes: int = 1 << 20) -> None:
        """Create a block of at least `nbytes` [bytes]."""
        self._shm: shared_memory.SharedMemory | None = None
        self._refs: dict[str, ArrayRef] = {}
        self._grow(nbytes)

    @property
    def name(self) -> str:
        """Return the block's system-wide name (what workers attach to)."""
        if self._shm is None:
            raise ParallelError("shared frame: used after close()")
        return self._shm.name

    def _grow(self, nbytes: int) -> None:
        self.close()
        self._shm = shared_memory.SharedMemory(create=True, size=max(int(nbytes), _ALIGN))

    def place(self, inputs: Mapping[str, np.ndarray], outputs: Mapping[str, tuple[tuple[int, ...], np.dtype]]) -> dict[str, ArrayRef]:
        """Lay out and copy `inputs` and reserve `outputs` (name → (shape, dtype)); return every array's ref.

        The block grows (a new name) when the frame does not fit; earlier refs are void after a call.
        """
        refs: dict[str, ArrayRef] = {}
        offset = 0
        for name, arr in inputs.items():
            refs[name] = ArrayRef(offset, tuple(int(s) for s in arr.shape), np.dtype(arr.dtype).str)
            offset += -(-refs[name].nbytes // _ALIGN) * _ALIGN
        for name, (shape, dtype) in outputs.items():
            if name in refs:
                raise ParallelError(f"shared frame: {name!r} is both an input and an output")
            refs[name] = ArrayRef(offset, tuple(int(s) for s in shape), np.dtype(dtype).str)
            offset += -(-refs[name].nbytes // _ALIGN) * _ALIGN
        assert self._shm is not None
        if offset > self._shm.size:
            self._grow(max(offset, 2 * self._shm.size))
        self._refs = refs
        for name, arr in inputs.items():
            np.copyto(self.array(name), arr, casting="no")
        return refs

    def array(self, name: str) -> np.ndarray:
        """Return the placed array `name` as a view of the block (valid until the next `place`)."""
        if self._shm is None:
            raise ParallelError("shared frame: used after close()")
        return view(self._shm.buf, self._refs[name])

    def view(self, ref: ArrayRef) -> np.ndarray:
        """Return the array `ref` (from the last `place`) describes as a view of the block."""
        if self._shm is None:
            raise ParallelError("shared frame: used after close()")
        return view(self._shm.buf, ref)

    def close(self) -> None:
        """Release and remove the block (idempotent)."""
        if self._shm is not None:
            shm, self._shm = self._shm, None
            self._refs = {}
            shm.close()
            shm.unlink()


def attach(name: str) -> shared_memory.SharedMemory:
    """Map the host's block `name` in a worker; the host alone removes it.

    A spawned worker shares the host's resource tracker, so its registration of the block is the
    host's own entry: the block outlives the worker and is removed once, by the host (or, if the
    host dies, by the tracker).
    """
    return shared_memory.SharedMemory(name=name, create=False)
