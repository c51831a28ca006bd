"""Frame arena: the CPU stage's output arrays, allocated once and reused frame after frame.

Fresh arrays cost a page fault per 4 KiB on first write: ~13 MB a frame at 65,536 lights,
about 5 ms on the 2-core test machine, as much as the tree build.  Engines allocate this
memory up front (tree paper 4.1); the arena does the same.  An array it hands out is valid
until the same name is asked for again, i.e. until the next frame's build.  Pass no arena
(None) to get fresh arrays, as tests that keep two builds do.
"""
from __future__ import annotations

import numpy as np


class Arena:
    def __init__(self):
        self._bufs: dict[str, np.ndarray] = {}

    def empty(self, name: str, shape, dtype) -> np.ndarray:
        dtype = np.dtype(dtype)
        shape = (shape,) if np.isscalar(shape) else tuple(shape)
        need = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        buf = self._bufs.get(name)
        if buf is None or buf.nbytes < need:
            buf = np.empty(max(need + need // 4, 64), np.uint8)   # 25% headroom against regrowth
            self._bufs[name] = buf
        return buf[:need].view(dtype).reshape(shape)

    @property
    def nbytes(self) -> int:
        return sum(b.nbytes for b in self._bufs.values())


def empty(arena: Arena | None, name: str, shape, dtype) -> np.ndarray:
    return np.empty(shape, dtype) if arena is None else arena.empty(name, shape, dtype)


def zeros(arena: Arena | None, name: str, shape, dtype) -> np.ndarray:
    if arena is None:
        return np.zeros(shape, dtype)
    a = arena.empty(name, shape, dtype)
    a.fill(0)
    return a
