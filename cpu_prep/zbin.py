"""Drobot 2017, "Improved Culling for Tiled and Clustered Rendering": the CPU side of Z-binning
and flat bit arrays.  numpy in, GPU-layout numpy arrays out, no OpenGL.

    lights sorted by view depth (the frame's sort): light N = bit N = id N of the LUT
    zbins[b]  = MIN_LIGHT_ID_IN_BIN | MAX_LIGHT_ID_IN_BIN << 16     (uint32, 2 x 16 bit)
                empty bin: MAX_ID | 0 (min > max, so its loop runs zero times)
                b = int(linear depth * bins / max_depth), uniform bins, the last one open-ended
    tile_bits[tile * words + N / 32] bit N % 32 = light N's screen rectangle touches the tile
                (tile = ty * tiles_x + tx, ty from the bottom, as cpu_prep.grid)

Widths and fallbacks (cpu_prep/limits.py; nothing is ever wrapped):
  * 16-bit ids hold lights 0..65,535, so up to ZBIN_NARROW_MAX_LIGHTS = 65,536 visible lights
    use the slides' 2 x 16-bit entry.  Past that the LUT takes 2 x 32-bit entries
    (uvec2 (min, max) per bin; `wide=True`; the shader's ZBIN_WIDE=1): twice the bytes of a
    LUT (64 KiB at 8096 bins), the same loop.  The empty entry of the wide LUT is
    ZBIN_WIDE_EMPTY_MIN | 0, the largest id a signed 32-bit difference holds, because the
    slides' mask arithmetic subtracts ids as ints.
  * A bit array is tiles x words x 4 bytes (65,536 lights in 8 px tiles at 1920x1080:
    265 MB).  As Unity URP's Forward+ does, the tile doubles until the bit arrays fit the
    memory budget (`choose_tile`); they never pass the storage-block limit.

Conservativeness against the float32 GPU test: the screen rectangles are cpu_prep.grid's
(Mara-McGuire, PIXEL_MARGIN, radii grown by RADIUS_REL_MARGIN); the depth ranges are the
packed float32 ranges rounded outwards, and their bins widen by ZBIN_DEPTH_REL_MARGIN against
the GPU's float32 `depth * scale`.
"""
from __future__ import annotations

import numba
import numpy as np

from .arena import Arena, zeros
from .limits import MAX_STORAGE_BYTES, LimitError

ZBIN_ID_BITS = 16
ZBIN_NARROW_MAX_LIGHTS = 1 << ZBIN_ID_BITS     # ids 0..65,535
ZBIN_NARROW_EMPTY = 0xFFFF                     # MAX_ID | 0
ZBIN_WIDE_EMPTY_MIN = 0x7FFFFFFF
# The GPU bins a pixel as uint(float32(depth) * float32(scale)): one rounding of the product
# (2^-24 relative) before the truncation.  A light's bins widen by 1e-5 relative, 160x that.
ZBIN_DEPTH_REL_MARGIN = 1e-5
WORD_BITS = 32


def words_for(lights: int) -> int:
    """32-bit words of one tile's bit array (bit N = sorted light N)."""
    return -(-int(lights) // WORD_BITS)


def tiles_for(width: int, height: int, tile: int) -> tuple[int, int]:
    return -(-int(width) // tile), -(-int(height) // tile)


def bits_bytes(width: int, height: int, tile: int, lights: int) -> int:
    tx, ty = tiles_for(width, height, tile)
    return tx * ty * words_for(lights) * 4


def choose_tile(width: int, height: int, lights: int, min_tile: int, budget_bytes: int,
                slices: int = 1) -> int:
    """The bit arrays' tile: `min_tile` (Drobot: 8 px), doubled until tiles x slices x words
    x 4 bytes fit `budget_bytes` (Unity URP Forward+ doubles its tile size against a word
    budget), or until one tile covers the screen; `slices`: depth slices a tile (raster's
    cluster rasterizer), else 1.  Refuses (LimitError) bit arrays past the storage-block
    limit, which one screen-sized tile only reaches past a billion lights."""
    tile = int(min_tile)
    budget = min(int(budget_bytes), MAX_STORAGE_BYTES)
    need = lambda t: bits_bytes(width, height, t, lights) * slices
    while need(tile) > budget and tile < max(width, height):
        tile *= 2
    if need(tile) > MAX_STORAGE_BYTES:
        raise LimitError(f"bit arrays of {lights} lights need {need(tile) / 2**20:.0f} MiB even in "
                         f"one screen-sized tile, over the {MAX_STORAGE_BYTES >> 20} MiB storage-block limit")
    return tile


# ---- Z bins --------------------------------------------------------------------------

def bin_scale(bins: int, max_depth: float) -> np.float32:
    """The GPU's bins per metre, as the float32 uniform it receives: bin = depth * scale."""
    return np.float32(bins / max(float(max_depth), 1e-30))


def light_bins(depth_lo, depth_hi, scale, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Inclusive bin range (b0, b1) of each light's conservative depth range [lo, hi]: every
    bin the GPU can compute for a pixel the light may affect.  Depths past the last bin's
    start land in the last bin (the GPU clamps the same way)."""
    s = float(scale)
    lo = np.asarray(depth_lo, np.float64) * s * (1.0 - ZBIN_DEPTH_REL_MARGIN)
    hi = np.asarray(depth_hi, np.float64) * s * (1.0 + ZBIN_DEPTH_REL_MARGIN)
    last = bins - 1
    b0 = np.clip(np.floor(np.minimum(lo, last)), 0, last).astype(np.int64)
    b1 = np.clip(np.floor(np.minimum(hi, last)), -1, last).astype(np.int64)   # -1: behind the eye
    return b0, b1


@numba.njit(inline="always")
def _find(nxt, i):
    """Next unpainted bin >= i (union-find with path halving)."""
    while nxt[i] != i:
        nxt[i] = nxt[nxt[i]]
        i = nxt[i]
    return i


@numba.njit(cache=True, nogil=True)
def _paint(b0, b1, bins, ids, out):
    """out[b] = the first id (in the order `ids` visits lights) whose range holds bin b;
    untouched bins keep their value.  Each bin is painted once: O(lights + bins)."""
    nxt = np.arange(bins + 1)
    for k in range(ids.shape[0]):
        i = ids[k]
        lo, hi = b0[i], b1[i]
        if lo > hi:
            continue
        j = _find(nxt, lo)
        while j <= hi:
            out[j] = i
            nxt[j] = j + 1
            j = _find(nxt, j + 1)


def bin_ranges(b0, b1, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """(min id, max id) of the lights whose bin range holds each bin; empty bins min > max
    (min = number of lights, max = -1)."""
    n = len(b0)
    lo = np.full(bins, n, np.int64)
    hi = np.full(bins, -1, np.int64)
    b0 = np.ascontiguousarray(b0, np.int64)
    b1 = np.ascontiguousarray(b1, np.int64)
    ids = np.arange(n, dtype=np.int64)
    _paint(b0, b1, bins, ids, lo)          # ascending ids: the first painter is the minimum
    _paint(b0, b1, bins, ids[::-1].copy(), hi)
    return lo, hi


def is_wide(lights: int) -> bool:
    """Whether the LUT needs 32-bit ids (more than 65,536 visible lights)."""
    return int(lights) > ZBIN_NARROW_MAX_LIGHTS


def pack_lut(lo: np.ndarray, hi: np.ndarray, lights: int) -> np.ndarray:
    """The slides' LUT: uint32 min | max << 16 per bin (empty: MAX_ID | 0); past 65,536
    lights the wide fallback, (bins, 2) uint32 (min, max) (empty: ZBIN_WIDE_EMPTY_MIN, 0)."""
    empty = lo > hi
    if is_wide(lights):
        if lights > ZBIN_WIDE_EMPTY_MIN:
            raise LimitError(f"zbin: {lights} lights exceed the 31-bit ids of the wide LUT")
        out = np.empty((len(lo), 2), np.uint32)
        out[:, 0] = np.where(empty, ZBIN_WIDE_EMPTY_MIN, lo)
        out[:, 1] = np.where(empty, 0, hi)
        return out
    if len(lo) and (hi.max(initial=-1) >= ZBIN_NARROW_MAX_LIGHTS):
        raise LimitError("zbin: a light id past 16 bits in the narrow LUT")   # never reached
    mn = np.where(empty, ZBIN_NARROW_EMPTY, lo).astype(np.uint32)
    mx = np.where(empty, 0, hi).astype(np.uint32)
    return mn | (mx << np.uint32(16))


def unpack_lut(lut: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(min id, max id) per bin of either LUT format, as the shader reads them."""
    lut = np.asarray(lut, np.uint32)
    if lut.ndim == 2:
        return lut[:, 0].astype(np.int64), lut[:, 1].astype(np.int64)
    return (lut & 0xFFFF).astype(np.int64), (lut >> 16).astype(np.int64)


def zbin_lut(depth_lo, depth_hi, bins: int, max_depth: float) -> tuple[np.ndarray, np.float32]:
    """(LUT, float32 scale) of depth-sorted lights: the CPU half of the slides' algorithm."""
    scale = bin_scale(bins, max_depth)
    b0, b1 = light_bins(depth_lo, depth_hi, scale, bins)
    lo, hi = bin_ranges(b0, b1, bins)
    return pack_lut(lo, hi, len(b0)), scale


# ---- flat bit arrays -----------------------------------------------------------------

@numba.njit(cache=True, nogil=True, parallel=True)
def _fill_bits(boxes, tiles_x, tiles_y, words, bands, bits):
    """Each light's bit into every tile of its box (tx0, tx1, ty0, ty1, ...); bands of tile
    rows in parallel, so no two threads write one word."""
    for band in numba.prange(bands):
        r0, r1 = band * tiles_y // bands, (band + 1) * tiles_y // bands
        for i in range(boxes.shape[0]):
            y0, y1 = max(boxes[i, 2], r0), min(boxes[i, 3], r1 - 1)
            x0, x1 = boxes[i, 0], boxes[i, 1]
            if x0 > x1:
                continue
            w = i >> 5
            b = np.uint32(1) << np.uint32(i & 31)
            for ty in range(y0, y1 + 1):
                row = ty * tiles_x
                for tx in range(x0, x1 + 1):
                    bits[(row + tx) * words + w] |= b


def tile_bits(boxes: np.ndarray, tiles_x: int, tiles_y: int, lights: int,
              arena: Arena | None = None) -> np.ndarray:
    """(tiles * words,) uint32 flat bit arrays from (N, >=4) int tile boxes (inclusive
    tx0, tx1, ty0, ty1; empty when tx0 > tx1 or ty0 > ty1) of the depth-sorted lights."""
    words = words_for(lights)
    bits = zeros(arena, "zbin_bits", tiles_x * tiles_y * words, np.uint32)
    if lights and len(bits):
        bands = max(1, min(tiles_y, numba.get_num_threads()))
        _fill_bits(np.ascontiguousarray(boxes[:, :4], np.int32), tiles_x, tiles_y, words, bands, bits)
    return bits


def bits_of_tile(bits: np.ndarray, tile: int, lights: int) -> np.ndarray:
    """The sorted light indices whose bit is set in one tile (tests, tools)."""
    words = words_for(lights)
    w = np.asarray(bits[tile * words:(tile + 1) * words], np.uint32)
    idx = np.nonzero(np.unpackbits(w.view(np.uint8), bitorder="little"))[0]
    return idx[idx < lights]


# ---- the GPU's word mask (tests, and the wave replay's kernels: app.model.waves) ----------

@numba.njit(cache=True)
def bit_field_mask(width: int, offset: int) -> int:
    """GCN's v_bfm_b32 (the slides' BitFieldMask): ((1 << (width & 31)) - 1) << (offset & 31),
    32 bits; width 32 wraps to 0, hence the listing's manual case."""
    return (((1 << (width & 31)) - 1) << (offset & 31)) & 0xFFFFFFFF


@numba.njit(cache=True)
def range_mask(lo: int, hi: int, word: int) -> int:
    """Bits of `word` that hold lights lo..hi (inclusive; none when lo > hi): the shader's
    default Z-bin mask (glsl/shade_zbin.comp range_mask)."""
    a = min(max(lo - word * 32, 0), 32)
    b = min(max(hi - word * 32, -1), 31) + 1
    width = max(b - a, 0)
    return 0xFFFFFFFF if width == 32 else bit_field_mask(width, a)


@numba.njit(cache=True)
def zbin_word_mask(min_idx: int, max_idx: int, word: int) -> int:
    """The slides' per-lane Z-bin mask of one word, as printed (int arithmetic as in the
    listing).  It clamps the start into the word but keeps the width of the whole range, so
    it is conservative but leaks: bit 31 of every word before the range, the tail of the
    range's last word past max_idx, and, once the range is 32 or wider, every whole word
    (the first word's head below min_idx too: the 32-wide case is the full mask).  The
    shader's ZBIN_PRINTED_MASK."""
    local_min = min(max(min_idx - word * 32, 0), 31)
    width = min(max(max_idx - min_idx + 1, 0), 32)
    return 0xFFFFFFFF if width == 32 else bit_field_mask(width, local_min)


__all__ = ["words_for", "tiles_for", "bits_bytes", "choose_tile", "bin_scale", "light_bins",
           "bin_ranges", "is_wide", "pack_lut", "unpack_lut", "zbin_lut", "tile_bits",
           "bits_of_tile", "bit_field_mask", "range_mask", "zbin_word_mask"]
