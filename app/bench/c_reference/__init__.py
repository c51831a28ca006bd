"""The plain single-threaded C reference of the hybrid's (and clustered's) CPU stage, for
point lights (the bar: our numba stage at or under plain single-threaded C).

    lean_ref.c          the same stage as the tree paper describes it, written apart from
                        the lab (float32, no margins, no light shapes, 32-byte rows):
                        what the design costs (app.bench.c_reference.lean: LeanReference)
    hybrid_ref.c        cull, radix sort, gather into depth order (GPU rows, screen
                        rectangles, depth ranges), binning, listing 2's plan, the trees: plain
                        scalar loops, each step timed inside C, every output bit for bit ours
    CReference()        compiles it on first use into the cache folder (XDG_CACHE_HOME or
                        ~/.cache, many-light-lab/c_reference/, the source's hash in the name:
                        rebuilt when the .c changes) and loads it with ctypes
    ref.frame(...)      one frame from what our hybrid build takes (scene light records, a
                        FrameCamera, the grid's tile / slices / near slice depth, the max
                        depth, lights_per_leaf, max_leaves, radius_scale): CFrame, numpy
                        arrays and the ms of each step

A missing C compiler, a failed build or a scene with other lights than points raises
CReferenceError (a UserError: the CLI prints its one line).  The arrays of a CFrame are
views of the C side's buffers, valid until that CReference's next frame or close() (as an
arena's): copy what must outlive them.
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass
import hashlib
import os
from pathlib import Path
import shutil
import subprocess
import tempfile

import numpy as np

from ...errors import UserError

SOURCE = Path(__file__).with_name("hybrid_ref.c")
# -march=native: numba compiles for the host CPU too; no contraction (fused multiply-add)
# and no fast-math: the outputs must be our kernels' bits (hybrid_ref.c's header)
CFLAGS = ("-O2", "-march=native", "-ffp-contract=off", "-fno-fast-math", "-shared", "-fPIC")
STEPS = ("cull", "sort", "gather", "bin", "plan", "build")      # ref_out.ms, in order


class CReferenceError(UserError):
    """The C reference cannot run here (no compiler, a failed build) or on this input."""


class _Out(ctypes.Structure):
    _fields_ = [("visible", ctypes.c_int64), ("cells", ctypes.c_int64),
                ("entries", ctypes.c_int64), ("nodes", ctypes.c_int64),
                ("sorted", ctypes.c_void_p), ("rows", ctypes.c_void_p), ("rect", ctypes.c_void_p),
                ("depth_lo", ctypes.c_void_p), ("depth_hi", ctypes.c_void_p),
                ("offsets", ctypes.c_void_p), ("entry", ctypes.c_void_p),
                ("ranges", ctypes.c_void_p), ("node", ctypes.c_void_p),
                ("is_tree", ctypes.c_void_p), ("ms", ctypes.c_double * len(STEPS))]


@dataclass
class CFrame:
    """One frame of the C reference: the arrays our build makes, and the ms of each step."""
    sorted: np.ndarray      # (N,) uint64 key << 32 | scene id, depth order (sort_ids())
    ids: np.ndarray         # (N,) uint32 scene ids in depth order
    gpu: np.ndarray         # (N,) GPU_LIGHT
    rect: np.ndarray        # (N, 4) float64 x0, x1, y0, y1
    depth_lo: np.ndarray    # (N,) float32
    depth_hi: np.ndarray    # (N,) float32
    offsets: np.ndarray     # (cells + 1,) int64 CSR offsets
    entries: np.ndarray     # (entries,) uint32
    ranges: np.ndarray      # (cells,) CELL_RANGE: hybrid's (first node, count | tree bit),
                            # clustered's (first entry, count)
    nodes: np.ndarray       # TREE_NODE[] (empty for clustered)
    is_tree: np.ndarray     # (cells,) bool (all False for clustered)
    ms: dict                # {step: ms} of STEPS

    @property
    def total_ms(self) -> float:
        return float(sum(self.ms.values()))


def cache_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "many-light-lab" / "c_reference"


def compiler() -> str:
    cc = os.environ.get("CC") or "cc"
    path = shutil.which(cc)
    if path is None:
        raise CReferenceError(f"the C reference needs a C compiler: '{cc}' is not on PATH "
                              f"(install gcc: sudo apt-get install gcc, or bash scripts/setup.sh)")
    return path


def library_path(cc: str | None = None, source: Path | None = None, flags=None) -> Path:
    """Where the build of the current `source` (default SOURCE) and flags lives; built if
    absent."""
    cc = cc or compiler()
    source, flags = source or SOURCE, CFLAGS if flags is None else flags
    src = source.read_bytes()
    h = hashlib.sha256(src + " ".join((os.path.basename(cc),) + tuple(flags)).encode()).hexdigest()[:16]
    out = cache_dir() / f"{source.stem}-{h}.so"
    if out.exists():
        return out
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(suffix=".so", dir=out.parent)
    except OSError as exc:
        raise CReferenceError(f"the C reference's cache folder {out.parent} is not writable "
                              f"({exc.strerror}); set XDG_CACHE_HOME") from None
    os.close(fd)
    try:
        r = subprocess.run([cc, *flags, "-o", tmp, str(source), "-lm"],
                           capture_output=True, text=True)
        if r.returncode != 0:
            first = (r.stderr.strip().splitlines() or ["(no message)"])[0]
            raise CReferenceError(f"building the C reference failed ({cc}): {first}")
        os.replace(tmp, out)          # atomic: a concurrent build writes the same bytes
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return out


def _check_layout(lib) -> None:
    from scenes.model import LIGHT_DTYPE
    sizes = (ctypes.c_int64 * 2)()
    lib.ref_struct_sizes(sizes)
    want = {"type": 0, "position": 4, "radius": 16, "color": 20, "intensity": 32,
            "direction": 36, "cos_inner": 48, "cos_outer": 52, "length": 56, "up": 60,
            "extent": 72}
    got = {k: LIGHT_DTYPE.fields[k][1] for k in want}
    if got != want or LIGHT_DTYPE.itemsize != sizes[0] or ctypes.sizeof(_Out) != sizes[1]:
        raise CReferenceError("the C reference's light record or result struct no longer "
                              "matches scenes.model.LIGHT_DTYPE / _Out: update hybrid_ref.c")


def native_array(addr: int, dtype, count: int) -> np.ndarray:
    """`count` elements of `dtype` at a compiled reference's output address, viewed in place
    (valid until its context's next frame or close); empty for a null or empty output."""
    if count == 0 or not addr:
        return np.zeros(0, dtype)
    buf = (ctypes.c_char * (count * np.dtype(dtype).itemsize)).from_address(addr)
    return np.frombuffer(buf, dtype, count)


class NativeContext:
    """A compiled C library with one context of its own, reused frame to frame: its
    `<prefix>_new`, `<prefix>_free` and `<prefix>_struct_sizes`."""
    prefix = ""
    what = ""                      # its name in error messages

    def _open(self, path: Path):
        try:
            lib = ctypes.CDLL(str(path))
        except OSError as exc:
            raise CReferenceError(f"loading {self.what} {path} failed: {exc}") from None
        getattr(lib, f"{self.prefix}_new").restype = ctypes.c_void_p
        getattr(lib, f"{self.prefix}_free").argtypes = [ctypes.c_void_p]
        getattr(lib, f"{self.prefix}_struct_sizes").argtypes = [ctypes.c_void_p]
        return lib

    def _start(self, lib, path: Path) -> None:
        self._lib, self.path = lib, path
        self._ctx = getattr(lib, f"{self.prefix}_new")()
        if not self._ctx:
            raise CReferenceError(f"{self.what} ran out of memory")

    def close(self) -> None:
        if getattr(self, "_ctx", None):
            getattr(self._lib, f"{self.prefix}_free")(self._ctx)
            self._ctx = None

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass


class CReference(NativeContext):
    """The compiled reference and its frame buffers (one context: reused frame to frame)."""
    prefix, what = "ref", "the C reference"

    def __init__(self):
        path = library_path()
        lib = self._open(path)
        d, i64, p = ctypes.c_double, ctypes.c_int64, ctypes.c_void_p
        lib.ref_frame.restype = ctypes.c_int
        lib.ref_frame.argtypes = [p, p, i64, p, d, d, d, d, d, d, d, d, d, i64, i64, i64,
                                  p, i64, p, p, d, i64, i64, ctypes.c_int, ctypes.POINTER(_Out)]
        _check_layout(lib)
        self._out = _Out()
        self._start(lib, path)

    def frame(self, lights: np.ndarray, cam, tile: int, slices: int, near_slice_depth: float,
              max_depth: float, lights_per_leaf: int = 6, max_leaves: int = 64,
              radius_scale: float = 1.0, hybrid: bool = True) -> CFrame:
        """One frame of the hybrid's CPU stage (hybrid False: clustered's, no plan or trees)
        on scene `lights` (LIGHT_DTYPE, points only) seen by FrameCamera `cam`, on the grid
        cpu_prep.grid.make_grid(cam, tile, slices, max_depth, near_slice_depth) gives."""
        from cpu_prep import grid as gridmod, hybrid as hybridmod, layouts, limits, tree
        from scenes.model import LIGHT_DTYPE, LIGHT_POINT, LIGHT_TYPES
        if lights.dtype != LIGHT_DTYPE:
            raise CReferenceError("the C reference takes scenes.model.LIGHT_DTYPE records")
        other = lights["type"] != LIGHT_POINT
        if other.any():
            kinds = sorted({LIGHT_TYPES[t] if t < len(LIGHT_TYPES) else str(t)
                            for t in np.unique(lights["type"][other])})
            raise CReferenceError(f"the C reference handles point lights only; this scene has "
                                  f"{int(other.sum())} others ({', '.join(kinds)})")
        try:
            tree._check_leaf_args(int(lights_per_leaf), int(max_leaves))
            tree._check_skip(int(max_leaves))
            grid = gridmod.make_grid(cam, int(tile), int(slices), max_depth, near_slice_depth)
        except ValueError as exc:                  # (LimitError is a ValueError)
            raise CReferenceError(str(exc)) from None
        lights = np.ascontiguousarray(lights)
        view = np.ascontiguousarray(cam.view_from_world, np.float64)
        table = np.ascontiguousarray(gridmod.slice_table(grid), np.float64)
        lo_s, hi_s = (np.ascontiguousarray(a, np.float64)
                      for a in hybridmod.cell_depth_ranges(grid, max_depth))
        # the cull's side planes, widened by a pixel, as cpu_prep.lights.cull passes them
        tx = cam.tan_half_x * (1.0 + 2.0 * limits.PIXEL_MARGIN / cam.width)
        ty = cam.tan_half_y * (1.0 + 2.0 * limits.PIXEL_MARGIN / cam.height)
        ptr = lambda a: a.ctypes.data_as(ctypes.c_void_p)
        o = self._out
        rc = self._lib.ref_frame(
            self._ctx, ptr(lights), len(lights), ptr(view), cam.near, cam.far, tx, ty,
            cam.tan_half_x, cam.tan_half_y, float(cam.width), float(cam.height),
            float(grid.tile), grid.tiles_x, grid.tiles_y, grid.slices, ptr(table), len(table),
            ptr(lo_s), ptr(hi_s), float(radius_scale), int(lights_per_leaf), int(max_leaves),
            int(bool(hybrid)), ctypes.byref(o))
        if rc != 0:
            raise CReferenceError("the C reference ran out of memory")
        n, cells = int(o.visible), int(o.cells)

        arr = native_array
        sorted_ = arr(o.sorted, np.uint64, n)
        rows = arr(o.rows, np.float32, n * layouts.LIGHT_WORDS).view(layouts.GPU_LIGHT)
        try:                           # the limits our stage meets (cpu_prep.frame, grid)
            limits.check_buffer("light buffer", rows.nbytes)
            limits.check_buffer("light index list", 4 * int(o.entries))
        except limits.LimitError as exc:
            raise CReferenceError(str(exc)) from None
        return CFrame(
            sorted=sorted_, ids=rows["id_type"][:, 0], gpu=rows,
            rect=arr(o.rect, np.float64, 4 * n).reshape(n, 4),
            depth_lo=arr(o.depth_lo, np.float32, n), depth_hi=arr(o.depth_hi, np.float32, n),
            offsets=arr(o.offsets, np.int64, cells + 1),
            entries=arr(o.entry, np.uint32, int(o.entries)),
            ranges=arr(o.ranges, np.uint32, 2 * cells).view(layouts.CELL_RANGE),
            nodes=arr(o.node, np.uint32, 4 * int(o.nodes)).view(layouts.TREE_NODE),
            is_tree=(arr(o.is_tree, np.uint8, cells).astype(bool) if hybrid
                     else np.zeros(cells, bool)),
            ms={k: float(o.ms[j]) for j, k in enumerate(STEPS)})
