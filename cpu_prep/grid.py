"""Screen tiles and the 2.5D frustum grid: depth slices (tree paper listing 4), each light's
box of cells, and the scatter of lights into per-cell index lists (CSR).

    cell id = (ty * tiles_x + tx) * slices + slice         (tx, ty from the bottom-left, GL)
    offsets[cell] .. offsets[cell+1]  ->  entries[]  (positions in the depth-sorted light list)

Cells are tile-major: the slices of one tile are neighbours in memory, so the scatter's
writes for one light (its tiles x its slices) land in a few nearby places, not one per
slice a whole slice's worth of lists apart (2.4x faster binning at 65,536 lights).

Lights arrive sorted by depth and the scatter walks them in that order, so every cell's list
comes out depth-sorted with no per-cell sort (tree paper 3.2).

The binning of a frame (bin_rects) is two passes over the lights and one over the cells:

    boxes + count   each light's cell box from its rectangle and depth range, and its eight
                    corners added to a 3D difference array (O(1) a light)
    offsets         prefix sums of that array: every cell's count, the CSR offsets
    fill            each light's index written into the cells of its box

A light's slice range comes from a table of the depths where listing 4 steps (two
logarithms a light were half the box pass), its tiles from a multiplication by the tile's
reciprocal with an exact correction (four divisions a light); both give listing 4's and
floor(x / tile)'s results (tests/cpu_prep/test_grid.py).  The fill writes 1M entries at
65,536 lights into 14,720 lists: it is bound by those scattered stores (~3 ns an entry
with cold caches), the cost the tree paper's figure 4 calls binning.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
import math

import numba
import numpy as np

from . import parallel, share
from .arena import Arena, empty, zeros
from .camera import FrameCamera
from .intrinsics import bits_to_f64, fetch_add
from .limits import SLICE_DEPTH_REL_MARGIN, check_buffer

FILL_BANDS_A_THREAD = 2
BOX_CHUNKS = 16       # with threads: chunks of lights for the boxes and counts


@dataclass(frozen=True)
class Grid:
    width: int
    height: int
    tile: int
    slices: int             # 1 = plain 2D tiles
    log_min: float          # log of the near slice's far end
    log_max: float          # log of the max depth worth slicing

    @property
    def tiles_x(self) -> int:
        return -(-self.width // self.tile)

    @property
    def tiles_y(self) -> int:
        return -(-self.height // self.tile)

    @property
    def cells(self) -> int:
        return self.tiles_x * self.tiles_y * self.slices

    # Listing 4 as printed computes scale = 1 / ((logMax - logMin) * (S - 1)), which crowds
    # every depth past the near slice into slices 1-2.  The intent (slice 0 the near slice,
    # 1..S-1 exponential over [minDepth, maxDepth]) is scale = (S - 1) / (logMax - logMin).
    @property
    def slice_scale(self) -> float:
        return (self.slices - 1) / (self.log_max - self.log_min) if self.slices > 1 else 0.0

    @property
    def slice_bias(self) -> float:
        return 1.0 - self.log_min * self.slice_scale if self.slices > 1 else 0.0

    def slice_of(self, depth) -> np.ndarray:
        """Listing 4 (scale corrected) for an array of depths; depth <= 0 goes to slice 0."""
        return _slices_of(np.ascontiguousarray(depth, np.float64).ravel(), self.slice_scale,
                          self.slice_bias, self.slices).reshape(np.shape(depth))

    def slice_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Depth range [near, far) of each slice; slice 0 starts at 0, the last ends at inf."""
        k = np.arange(self.slices, dtype=np.float64)
        lo = np.exp((k - self.slice_bias) / self.slice_scale) if self.slices > 1 else np.zeros(1)
        lo[0] = 0.0
        hi = np.append(lo[1:], np.inf)
        return lo, hi


def make_grid(cam: FrameCamera, tile: int, slices: int, max_depth: float,
              near_slice_depth: float) -> Grid:
    if tile < 1 or slices < 1:
        raise ValueError(f"tile ({tile}) and slices ({slices}) must be >= 1")
    max_depth = max(float(max_depth), cam.near * 4)
    # The near slice ends at near_slice_depth (Persson: 5 m), but never past a tenth of the
    # sliced range, so small interiors still get exponential slices.
    min_depth = min(near_slice_depth, max_depth / 10)
    return Grid(cam.width, cam.height, tile, slices, math.log(min_depth), math.log(max_depth))


@numba.njit(inline="always")
def slice_index(depth, scale, bias, slices):
    """Tree paper listing 4 with the scale corrected (see Grid); depth <= 0 -> slice 0."""
    if slices == 1 or depth <= 0.0:
        return 0
    s = max(math.log(depth) * scale + bias, 0.0)
    return int(min(s, slices - 1.0))


@numba.njit(cache=True, error_model="numpy")
def _slices_of(depth, scale, bias, slices):
    out = np.empty(depth.shape[0], np.int64)
    for i in range(depth.shape[0]):
        out[i] = slice_index(depth[i], scale, bias, slices)
    return out


@numba.njit(cache=True, error_model="numpy")
def _slice_table(scale, bias, slices):
    """The depths where slice_index() steps: table[k-1] is the smallest positive float64 d
    with slice_index(d) >= k (bisection on the float64 bit patterns, which order positive
    floats like their values; inf when no depth reaches slice k)."""
    out = np.empty(max(slices - 1, 0))
    for k in range(1, slices):
        lo, hi = 0, 0x7FF0000000000000        # +0.0 (slice 0 < k), +inf (slice S-1 >= k)
        while hi - lo > 1:
            mid = lo + (hi - lo) // 2
            if slice_index(bits_to_f64(mid), scale, bias, slices) >= k:
                hi = mid
            else:
                lo = mid
        out[k - 1] = bits_to_f64(hi)
    return out


def slice_table(grid: Grid) -> np.ndarray:
    """The depths where the grid's slice_index() steps (_slice_table()), padded with NaN to
    2^k - 1 entries (no depth compares >= NaN), for slice_from_table()'s branch-free binary
    search; empty for one slice.  Read-only, shared by grids of the same slicing."""
    return _table_for(grid.slice_scale, grid.slice_bias, grid.slices)


@lru_cache(maxsize=256)
def _table_for(scale: float, bias: float, slices: int) -> np.ndarray:
    t = _slice_table(scale, bias, slices)
    size = 1
    while size - 1 < len(t):
        size *= 2
    out = np.full(size - 1, np.nan)
    out[:len(t)] = t
    out.flags.writeable = False
    return out


@numba.njit(inline="always")
def slice_from_table(depth, table):
    """slice_index() as the number of the table's steps at or below `depth`, by a branch-
    free binary search (four compares for 16 slices) instead of a logarithm (two a light
    were half of the binning's box cost).  Equal to slice_index() at every float64 where
    that is monotone in depth (log is, to the ulp; tests/cpu_prep/test_grid.py checks both
    sides of every step); a step moved by an ulp would be far inside the
    SLICE_DEPTH_REL_MARGIN the depth ranges are widened by."""
    s = 0
    step = (table.shape[0] + 1) >> 1
    while step > 0:
        s += step if depth >= table[s + step - 1] else 0
        step >>= 1
    return s


@numba.njit(inline="always")
def tile_of(x, tile, inv_tile):
    """floor(x / tile) as a float, without a division (four a light): the product with the
    reciprocal is within an ulp of the quotient, so its floor is off by at most one, which
    the comparisons with q * tile (products of integers below 2^53: exact) correct, giving
    the floor of the true quotient for |x| < 2^40 pixels (beyond, a value past the grid
    either way, clamped alike).  For an integer tile that is floor(fl(x / tile)) too (the
    float just below tile * k is far enough below it that the rounded quotient stays below
    k), except for a negative subnormal x, whose quotient underflows to -0: the true floor,
    -1, is the right tile there (tests/cpu_prep/test_grid.py).  +-inf give +-inf."""
    q = np.floor(x * inv_tile)       # (np.floor: a float; math.floor is an int64)
    q = q - 1.0 if q * tile > x else q
    return q + 1.0 if (q + 1.0) * tile <= x else q


@numba.njit(inline="always")
def _box(x0, x1, y0, y1, d_lo, d_hi, tile, tiles_x, tiles_y, table):
    """Inclusive cell box (tx0, tx1, ty0, ty1, s0, s1) of a pixel rectangle and a depth
    range, clamped to the grid; empty (tx0 > tx1 ...) off screen.  Pixel p (centre p+0.5)
    lies in tile p // tile.  The depth range widens by SLICE_DEPTH_REL_MARGIN."""
    inv = 1.0 / tile
    tx0 = int(max(tile_of(x0, tile, inv), 0.0))
    tx1 = int(min(tile_of(x1, tile, inv), tiles_x - 1.0))
    ty0 = int(max(tile_of(y0, tile, inv), 0.0))
    ty1 = int(min(tile_of(y1, tile, inv), tiles_y - 1.0))
    s0 = slice_from_table(d_lo * (1.0 - SLICE_DEPTH_REL_MARGIN), table)
    s1 = slice_from_table(d_hi * (1.0 + SLICE_DEPTH_REL_MARGIN), table)
    return tx0, tx1, ty0, ty1, s0, s1


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _boxes_from_rects(rect, d_lo, d_hi, tile, tiles_x, tiles_y, table):
    out = np.empty((rect.shape[0], 6), np.int32)
    for i in range(rect.shape[0]):
        out[i] = _box(rect[i, 0], rect[i, 1], rect[i, 2], rect[i, 3], d_lo[i], d_hi[i],
                      tile, tiles_x, tiles_y, table)
    return out


def _grid_args(grid: Grid):
    return float(grid.tile), grid.tiles_x, grid.tiles_y, slice_table(grid)


def cell_boxes(grid: Grid, rect, depth_lo, depth_hi) -> np.ndarray:
    """(N, 6) int32 boxes (tx0, tx1, ty0, ty1, s0, s1) from pixel rectangles and depth ranges."""
    r = np.ascontiguousarray(np.stack(rect, 1), np.float64)
    return _boxes_from_rects(r, np.ascontiguousarray(depth_lo, np.float64),
                             np.ascontiguousarray(depth_hi, np.float64), *_grid_args(grid))


def rect_boxes(grid: Grid, rect, depth_lo, depth_hi, arena: Arena | None = None) -> np.ndarray:
    """(N, 6) boxes of lights from their conservative pixel rectangles (N, 4) and depth
    ranges (cpu_prep.lights: each shape's own bounds)."""
    out = empty(arena, "boxes", (len(rect), 6), np.int32)
    _rect_boxes(rect, depth_lo, depth_hi, *_grid_args(grid), out)
    return out


@numba.njit(inline="always")
def _store_box(i, rect, d_lo, d_hi, tile, tiles_x, tiles_y, table, out):
    """Light i's box of cells into out[i], and returned; an empty box (1, 0, ...) where
    nothing of the light can be seen."""
    x0, x1, y0, y1, lo, hi = rect[i, 0], rect[i, 1], rect[i, 2], rect[i, 3], float(d_lo[i]), float(d_hi[i])
    if not (x0 <= x1 and y0 <= y1 and lo <= hi):
        a0, a1, b0, b1, s0, s1 = 1, 0, 1, 0, 1, 0
    else:
        a0, a1, b0, b1, s0, s1 = _box(x0, x1, y0, y1, lo, hi, tile, tiles_x, tiles_y, table)
    # six stores, not out[i] = (tuple): numba lowers a tuple stored into an array row
    # through its general sequence setitem, 3 s of the cold compile of this loop
    out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4], out[i, 5] = a0, a1, b0, b1, s0, s1
    return a0, a1, b0, b1, s0, s1


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _rect_boxes(rect, d_lo, d_hi, tile, tiles_x, tiles_y, table, out):
    for i in range(rect.shape[0]):
        _store_box(i, rect, d_lo, d_hi, tile, tiles_x, tiles_y, table, out)


@numba.njit(inline="always")
def _add_corners(diff, x0, x1, y0, y1, s0, s1):
    """Add a non-empty box to the 3D difference array (8 corners): O(1) a light, not
    O(cells touched); the prefix sums over the three axes then give every cell's count.
    (Unsigned indices: no negative-index wraparound code.)"""
    x0, x1, y0, y1 = np.uint64(x0), np.uint64(x1 + 1), np.uint64(y0), np.uint64(y1 + 1)
    s0, s1 = np.uint64(s0), np.uint64(s1 + 1)
    diff[y0, x0, s0] += 1
    diff[y0, x0, s1] -= 1
    diff[y0, x1, s0] -= 1
    diff[y0, x1, s1] += 1
    diff[y1, x0, s0] -= 1
    diff[y1, x0, s1] += 1
    diff[y1, x1, s0] += 1
    diff[y1, x1, s1] -= 1


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _box_corners(boxes, diff):
    for i in range(boxes.shape[0]):
        x0, x1, y0, y1, s0, s1 = boxes[i, 0], boxes[i, 1], boxes[i, 2], boxes[i, 3], boxes[i, 4], boxes[i, 5]
        if x0 > x1 or y0 > y1 or s0 > s1:
            continue
        _add_corners(diff, x0, x1, y0, y1, s0, s1)


@numba.njit(inline="always")
def _boxes_corners_range(a, b, rect, d_lo, d_hi, tile, tiles_x, tiles_y, table, out, diff):
    """rect_boxes() and the difference-array count in one pass over lights a .. b-1."""
    for i in range(a, b):
        a0, a1, b0, b1, s0, s1 = _store_box(i, rect, d_lo, d_hi, tile, tiles_x, tiles_y, table, out)
        if a0 <= a1 and b0 <= b1 and s0 <= s1:
            _add_corners(diff, a0, a1, b0, b1, s0, s1)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _boxes_corners(rect, d_lo, d_hi, tile, tiles_x, tiles_y, table, out, diff):
    """rect_boxes() and the difference-array count in one pass over the lights."""
    _boxes_corners_range(0, rect.shape[0], rect, d_lo, d_hi, tile, tiles_x, tiles_y, table,
                         out, diff)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _boxes_corners_chunks(claim, chunks, rect, d_lo, d_hi, tile, tiles_x, tiles_y, table, out,
                          diffs):
    """_boxes_corners() on the chunks of lights this thread claims (cpu_prep.share), counted
    into this thread's own difference array, diffs[slot] (claim[2] hands out the slots):
    integer counts, so their sum is the same whichever thread counted which light."""
    slot = fetch_add(claim, 2, 1)
    n = rect.shape[0]
    k = fetch_add(claim, 0, 1)
    while k < chunks:
        _boxes_corners_range(k * n // chunks, (k + 1) * n // chunks, rect, d_lo, d_hi, tile,
                             tiles_x, tiles_y, table, out, diffs[slot])
        fetch_add(claim, 1, 1)
        k = fetch_add(claim, 0, 1)


def rect_counts(grid: Grid, rect, depth_lo, depth_hi) -> np.ndarray:
    """(tiles_y, tiles_x, slices) int64: per cell the lights whose box (rect_boxes(): the
    binning's rule) holds it, from the binning's difference array, without the lists."""
    diff = np.zeros((grid.tiles_y + 1, grid.tiles_x + 1, grid.slices + 1), np.int32)
    boxes = np.empty((len(rect), 6), np.int32)
    f64 = lambda a: np.ascontiguousarray(a, np.float64)
    _boxes_corners(f64(rect).reshape(-1, 4), f64(depth_lo), f64(depth_hi), *_grid_args(grid),
                   boxes, diff)
    counts = np.cumsum(np.cumsum(np.cumsum(diff, 0, np.int64), 1), 2)
    return counts[:grid.tiles_y, :grid.tiles_x, :grid.slices]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _offsets(diff, offsets, cursor):
    """Prefix sums of the difference array along slices, tiles x, tiles y (every cell's
    light count), then offsets[1:] = their running total in cell order and cursor = offsets[:-1]
    (the fill's write positions).  Returns the entry count."""
    ny, nx, ns = diff.shape[0] - 1, diff.shape[1] - 1, diff.shape[2] - 1
    for y in range(ny):
        for x in range(nx):
            acc = 0
            for s in range(ns):
                acc += diff[y, x, s]
                diff[y, x, s] = acc
    for y in range(ny):
        for x in range(1, nx):
            for s in range(ns):
                diff[y, x, s] += diff[y, x - 1, s]
    for y in range(1, ny):
        for x in range(nx):
            for s in range(ns):
                diff[y, x, s] += diff[y - 1, x, s]
    total = 0
    c = 0
    offsets[0] = 0
    for y in range(ny):
        for x in range(nx):
            for s in range(ns):
                cursor[c] = total
                total += diff[y, x, s]
                c += 1
                offsets[c] = total
    return total


@numba.njit(inline="always")
def _fill_band(boxes, tiles_x, tiles_y, slices, band, bands, cursor, entries):
    """Each light's index into every cell of its box (rows of this band), lights in order
    (so each cell's list keeps the depth order of the input); cursor starts as the cells'
    offsets.  A box of one slice (most lights) writes along its tile rows with a stride.
    Cell and entry indices are unsigned: numba then emits no negative-index wraparound
    for them (a sixth of the fill's time)."""
    S, TX = np.uint64(slices), np.uint64(tiles_x)
    row0, row1 = band * tiles_y // bands, (band + 1) * tiles_y // bands - 1   # the band's rows
    for i in range(boxes.shape[0]):
        x0, x1, s0, s1 = boxes[i, 0], boxes[i, 1], boxes[i, 4], boxes[i, 5]
        y0, y1 = max(boxes[i, 2], row0), min(boxes[i, 3], row1)
        if x0 > x1 or y0 > y1 or s0 > s1:
            continue
        nx = np.uint64(x1 - x0 + 1)
        v = np.uint32(i)
        if s0 == s1:
            for ty in range(y0, y1 + 1):
                c = (np.uint64(ty) * TX + np.uint64(x0)) * S + np.uint64(s0)
                for _ in range(nx):
                    p = cursor[c]
                    entries[np.uint64(p)] = v
                    cursor[c] = p + np.uint32(1)
                    c += S
        else:
            ns = np.uint64(s1 - s0 + 1)
            for ty in range(y0, y1 + 1):
                first = (np.uint64(ty) * TX + np.uint64(x0)) * S + np.uint64(s0)
                for _ in range(nx):
                    c = first
                    for _ in range(ns):
                        p = cursor[c]
                        entries[np.uint64(p)] = v
                        cursor[c] = p + np.uint32(1)
                        c += np.uint64(1)
                    first += S


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _fill_chunks(claim, bands, boxes, tiles_x, tiles_y, slices, cursor, entries):
    """The bands this thread claims (cpu_prep.share): no two write one cell."""
    band = fetch_add(claim, 0, 1)
    while band < bands:
        _fill_band(boxes, tiles_x, tiles_y, slices, band, bands, cursor, entries)
        fetch_add(claim, 1, 1)
        band = fetch_add(claim, 0, 1)


def _count_arrays(grid: Grid, arena: Arena | None):
    diff = zeros(arena, "bin_diff", (grid.tiles_y + 1, grid.tiles_x + 1, grid.slices + 1), np.int32)
    offsets = empty(arena, "offsets", grid.cells + 1, np.int64)
    cursor = empty(arena, "cursor", grid.cells, np.uint32)
    return diff, offsets, cursor


def _fill(grid: Grid, boxes, diff, offsets, cursor, arena: Arena | None) -> np.ndarray:
    total = _offsets(diff, offsets, cursor)
    check_buffer("light index list", 4 * total)   # before allocating; keeps the uint32 cursor exact
    entries = empty(arena, "entries", total, np.uint32)
    # with threads, bands of tile rows (each band reads every box: more bands, more reads)
    bands = min(grid.tiles_y, FILL_BANDS_A_THREAD * numba.get_num_threads()) if parallel() else 1
    share.run(_fill_chunks, bands, boxes, grid.tiles_x, grid.tiles_y, grid.slices, cursor, entries)
    return entries


def scatter(grid: Grid, boxes, arena: Arena | None = None) -> tuple[np.ndarray, np.ndarray]:
    """CSR (offsets int64 of length cells+1, entries uint32) of lights per cell; `boxes` of
    lights in depth order, so each cell's entries come out depth-sorted."""
    boxes = np.ascontiguousarray(boxes, np.int32)
    diff, offsets, cursor = _count_arrays(grid, arena)
    _box_corners(boxes, diff)
    return offsets, _fill(grid, boxes, diff, offsets, cursor, arena)


def bin_rects(grid: Grid, rect, depth_lo, depth_hi, arena: Arena | None = None):
    """rect_boxes() then scatter(), with the boxes and the count made in one pass:
    (offsets, entries, boxes)."""
    boxes = empty(arena, "boxes", (len(rect), 6), np.int32)
    diff, offsets, cursor = _count_arrays(grid, arena)
    _count_boxes(grid, rect, depth_lo, depth_hi, boxes, diff, arena)
    return offsets, _fill(grid, boxes, diff, offsets, cursor, arena), boxes


def _count_boxes(grid: Grid, rect, depth_lo, depth_hi, boxes, diff, arena: Arena | None):
    """The lights' boxes and their difference-array count (one pass); with threads, chunks
    of lights, a difference array a thread, summed into diff."""
    chunks = max(min(len(rect), BOX_CHUNKS), 1) if parallel() else 1
    if chunks == 1:
        share.run(_boxes_corners_chunks, 1, rect, depth_lo, depth_hi, *_grid_args(grid), boxes,
                  diff[None])
        return
    parts = zeros(arena, "bin_diff_parts", (numba.get_num_threads(),) + diff.shape, np.int32)
    share.run(_boxes_corners_chunks, chunks, rect, depth_lo, depth_hi, *_grid_args(grid), boxes,
              parts)
    np.sum(parts, axis=0, out=diff)
