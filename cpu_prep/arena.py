"""Frame arena: the CPU stage's output arrays, allocated once and reused frame after frame.

Fresh arrays cost a page fault per 4 KiB on first write: ~13 MB a frame at 65,536 lights,
about 5 ms on the 2-core test machine, as much as the tree build.  Engines allocate this
memory up front (tree paper 4.1); the arena does the same.  An array it hands out is valid
until the same name is asked for again, i.e. until the next frame's build.  Pass no arena
(None) to get fresh arrays, as tests that keep two builds do.
"""
from __future__ import annotations

import numpy as np


ALIGN = 64      # every buffer starts on a cache line (the pack's streaming stores need 16)


def _aligned_bytes(nbytes: int) -> np.ndarray:
    raw = np.empty(nbytes + ALIGN, np.uint8)
    off = -raw.ctypes.data % ALIGN
    return raw[off:off + nbytes]


def aligned_empty(shape, dtype) -> np.ndarray:
    """np.empty, starting on a cache line."""
    dtype = np.dtype(dtype)
    shape = (int(shape),) if isinstance(shape, (int, np.integer)) else tuple(int(s) for s in shape)
    n = 1
    for s in shape:
        n *= s
    return _aligned_bytes(n * dtype.itemsize).view(dtype).reshape(shape)


class Arena:
    def __init__(self):
        self._bufs: dict[str, np.ndarray] = {}

    def empty(self, name: str, shape, dtype) -> np.ndarray:
        dtype = np.dtype(dtype)
        shape = (int(shape),) if isinstance(shape, (int, np.integer)) else tuple(int(s) for s in shape)
        n = 1
        for s in shape:               # (not np.prod: a frame asks ~30 times)
            n *= s
        need = n * dtype.itemsize
        buf = self._bufs.get(name)
        if buf is None or buf.nbytes < need:
            buf = _aligned_bytes(max(need + need // 4, 64))    # 25% headroom against regrowth
            self._bufs[name] = buf
        return buf[:need].view(dtype).reshape(shape)

    @property
    def nbytes(self) -> int:
        return sum(b.nbytes for b in self._bufs.values())


def empty(arena: Arena | None, name: str, shape, dtype) -> np.ndarray:
    return aligned_empty(shape, dtype) if arena is None else arena.empty(name, shape, dtype)


def zeros(arena: Arena | None, name: str, shape, dtype) -> np.ndarray:
    if arena is None:
        return np.zeros(shape, dtype)
    a = arena.empty(name, shape, dtype)
    a.fill(0)
    return a
