"""The lean C (lean_ref.c): the hybrid's CPU stage as the tree paper describes it, written
apart from the lab, for point lights; built and loaded as hybrid_ref.c is.

    LeanReference()          compiles lean_ref.c on first use (the cache folder of
                             app.bench.c_reference, the source's hash in the name)
    ref.frame(lights, cam, grid, ...)
                             one frame: LeanFrame (numpy views of the C side's buffers,
                             valid until the next frame or close()) and the ms of each step

Where it differs from the lab by design (docs/cpu_stage.md): float32 arithmetic and no
margins (the cull's planes, the rectangle and the depth range are the sphere's own, so its
cells are a subset of the lab's, which widen each bound by a pixel, a relative 1e-5 of the
radius and 1e-4 of the depth); 32-byte light rows; leaves of consecutive runs of
lights_per_leaf lights (the lab balances a cell's lights over its leaves).
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import CReferenceError, NativeContext, library_path, native_array

SOURCE = Path(__file__).with_name("lean_ref.c")
# plain C: -O2 for the host CPU, the compiler's own floating-point contraction allowed
CFLAGS = ("-O2", "-march=native", "-shared", "-fPIC")
STEPS = ("cull", "sort", "gather", "bin", "plan", "build")      # lean_out.ms, in order

ROW = np.dtype([("pos_radius", np.float32, 4), ("color", np.float32, 3), ("id", np.uint32)])
BOX = np.dtype([(k, np.uint16) for k in ("x0", "x1", "y0", "y1", "s0", "s1")])
NODE = np.dtype([("min_depth", np.float32), ("max_depth", np.float32),
                 ("first_light", np.uint32), ("bits", np.uint32)])


class _Out(ctypes.Structure):
    _fields_ = [("visible", ctypes.c_int64), ("cells", ctypes.c_int64),
                ("entries", ctypes.c_int64), ("nodes", ctypes.c_int64)] + [
        (k, ctypes.c_void_p) for k in ("ids", "rows", "z", "boxes", "offsets", "entry",
                                       "ranges", "node", "is_tree")] + [
        ("ms", ctypes.c_double * len(STEPS))]


@dataclass
class LeanFrame:
    ids: np.ndarray         # (N,) uint32 scene ids in depth order
    rows: np.ndarray        # (N,) ROW
    depth: np.ndarray       # (N, 2) float32 depth extent (centre depth -+ radius)
    boxes: np.ndarray       # (N,) BOX, inclusive (x0 > x1: nothing on screen)
    offsets: np.ndarray     # (cells + 1,) uint32 CSR offsets
    entries: np.ndarray     # (entries,) uint32 depth-order positions
    ranges: np.ndarray      # (cells, 2) uint32 first node, node count | tree bit
    nodes: np.ndarray       # (nodes,) NODE
    is_tree: np.ndarray     # (cells,) bool
    ms: dict

    @property
    def total_ms(self) -> float:
        return float(sum(self.ms.values()))

    def cell_sets(self) -> list[frozenset]:
        """Each cell's lights as a set of scene ids."""
        ids = self.ids[self.entries]
        o = self.offsets
        return [frozenset(ids[o[c]:o[c + 1]].tolist()) for c in range(len(o) - 1)]


class LeanReference(NativeContext):
    """The compiled lean C and its frame buffers (reused frame to frame)."""
    prefix, what = "lean", "the lean C"

    def __init__(self):
        from scenes.model import LIGHT_DTYPE
        path = library_path(source=SOURCE, flags=CFLAGS)
        lib = self._open(path)
        f, i, p = ctypes.c_float, ctypes.c_int, ctypes.c_void_p
        lib.lean_frame.restype = ctypes.c_int
        lib.lean_frame.argtypes = [p, p, ctypes.c_int64, p, f, f, f, f, i, i, i, i, f, f, f, f,
                                   i, i, ctypes.POINTER(_Out)]
        sizes = (ctypes.c_int64 * 4)()
        lib.lean_struct_sizes(sizes)
        if (list(sizes) != [LIGHT_DTYPE.itemsize, ctypes.sizeof(_Out), ROW.itemsize, BOX.itemsize]
                or {k: LIGHT_DTYPE.fields[k][1] for k in ("type", "position", "radius", "color",
                                                          "intensity")}
                != {"type": 0, "position": 4, "radius": 16, "color": 20, "intensity": 32}):
            raise CReferenceError("lean_ref.c's structs no longer match LIGHT_DTYPE / lean.py")
        self._out = _Out()
        self._start(lib, path)

    def frame(self, lights: np.ndarray, cam, grid, max_depth: float, lights_per_leaf: int = 6,
              max_leaves: int = 64, radius_scale: float = 1.0) -> LeanFrame:
        """One frame on scene `lights` (LIGHT_DTYPE, points only: others are read as points
        of their radius; the caller refuses them) seen by FrameCamera `cam` on
        cpu_prep.grid.Grid `grid`."""
        if lights_per_leaf < 1 or max_leaves < 1 or max_leaves & (max_leaves - 1):
            raise CReferenceError("the lean C takes lights_per_leaf >= 1 and a power of two "
                                  "of max_leaves")
        lights = np.ascontiguousarray(lights)
        view = np.ascontiguousarray(cam.view_from_world, np.float64)
        o = self._out
        rc = self._lib.lean_frame(
            self._ctx, lights.ctypes.data, len(lights), view.ctypes.data, cam.near, cam.far,
            cam.tan_half_x, cam.tan_half_y, grid.width, grid.height, grid.tile, grid.slices,
            grid.log_min, grid.log_max, float(max_depth), float(radius_scale),
            int(lights_per_leaf), int(max_leaves), ctypes.byref(o))
        if rc == -1:
            raise CReferenceError("the lean C ran out of memory")
        if rc != 0:
            raise CReferenceError("the lean C takes at most 64 slices and 16,384 leaves a tree")
        n, cells = int(o.visible), int(o.cells)

        arr = native_array
        return LeanFrame(
            ids=arr(o.ids, np.uint32, n), rows=arr(o.rows, ROW, n),
            depth=arr(o.z, np.float32, 2 * n).reshape(n, 2), boxes=arr(o.boxes, BOX, n),
            offsets=arr(o.offsets, np.uint32, cells + 1),
            entries=arr(o.entry, np.uint32, int(o.entries)),
            ranges=arr(o.ranges, np.uint32, 2 * cells).reshape(cells, 2),
            nodes=arr(o.node, NODE, int(o.nodes)),
            is_tree=arr(o.is_tree, np.uint8, cells).astype(bool),
            ms={k: float(o.ms[j]) for j, k in enumerate(STEPS)})


def _pairs(ids, offsets, entries) -> np.ndarray:
    """Sorted (cell << 32 | scene id) of every list entry."""
    offsets = np.asarray(offsets, np.int64)
    cell = np.repeat(np.arange(len(offsets) - 1, dtype=np.int64), np.diff(offsets))
    return np.sort(cell << 32 | np.asarray(ids, np.int64)[np.asarray(entries, np.int64)])


def list_differences(f: LeanFrame, ids, offsets, entries) -> dict:
    """The lean C's per-cell light sets against a lab build's (scene ids `ids` in its depth
    order, its CSR `offsets` and `entries`): how many cells hold the same set, the
    (cell, scene id) pairs only the lean C has and only the lab has."""
    a, b = _pairs(f.ids, f.offsets, f.entries), _pairs(ids, offsets, entries)
    lean_only, ours_only = np.setdiff1d(a, b, True), np.setdiff1d(b, a, True)
    differ = np.union1d(lean_only >> 32, ours_only >> 32)
    return {"cells": len(f.offsets) - 1, "same_cells": len(f.offsets) - 1 - len(differ),
            "lean_entries": len(a), "our_entries": len(b),
            "lean_only": lean_only, "ours_only": ours_only}
