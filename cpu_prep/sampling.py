"""Light sampling's CPU side: the probability of every entry of a cell's light list, as the
sampling techniques draw from it (app/techniques/sample_list, sample_ris; glsl/sampling.glsl).

    cdf[entry] = the cell's masses up to and including this entry, in units of 2^-31;
                 the last entry of every cell holds MASS_TOTAL exactly

A pixel draws u uniform in [0, MASS_TOTAL) and takes the first entry of its cell with
u < cdf[entry]: the entry's probability is its mass / MASS_TOTAL, an integer ratio the shader
computes from the same two words it searched, so the weight 1/p it applies is the probability
it drew with (a float CDF would draw with the rounded gaps and weight with others).

An entry's mass is a cheap bound of what the light can add anywhere in the cell, its
brightest channel's intensity over the squared distance from its centre to the cell's
view-space box plus one (the light model's 1/(d^2 + 1) falloff: the attenuation window is at
most 1, so for points and spots this bounds the light's irradiance in the cell), mixed with
the uniform distribution over the list (defensive importance sampling, Hesterberg 1995):

    p = (1 - DEFENSIVE) w / sum(w) + DEFENSIVE / n,   every mass at least 1

so that every light of a list (a superset of the lights affecting the cell's pixels, exact
as clustered's) keeps a nonzero probability, and no weight exceeds n / DEFENSIVE.
"""
from __future__ import annotations

import numba
import numpy as np

from .camera import FrameCamera
from .grid import Grid

MASS_BITS = 31
MASS_TOTAL = 1 << MASS_BITS       # a cell's masses sum to this (u: 31 random bits)
DEFENSIVE = 0.1                   # share of the uniform mixture in every cell's distribution


def cell_view_boxes(grid: Grid, cam: FrameCamera) -> tuple[np.ndarray, np.ndarray]:
    """((cells, 3), (cells, 3)) float64: the view-space box (lo, hi) of every cell of the
    grid (cell id order, cpu_prep.grid): the box of the frustum cell's eight corners (tiles
    from the bottom-left, the last slice ending at the far plane)."""
    lo_d, hi_d = grid.slice_bounds()
    hi_d = np.minimum(hi_d, cam.far)
    lo_d = np.minimum(lo_d, hi_d)
    tx, ty = np.arange(grid.tiles_x), np.arange(grid.tiles_y)
    # the tile's edges in NDC, times the view-space half extent per unit depth
    x = np.stack([tx * grid.tile, np.minimum((tx + 1) * grid.tile, grid.width)], 1) / grid.width
    y = np.stack([ty * grid.tile, np.minimum((ty + 1) * grid.tile, grid.height)], 1) / grid.height
    x = (2.0 * x - 1.0) * cam.tan_half_x
    y = (2.0 * y - 1.0) * cam.tan_half_y
    depth = np.stack([lo_d, hi_d], 1)                                   # (slices, 2)
    # corners: x edge a, depth b -> x[a] * depth[b]; the box spans their min and max
    xs = x[:, :, None, None] * depth.T[None, None]                      # (tx, 2, 2, slices)
    ys = y[:, :, None, None] * depth.T[None, None]
    x_lo, x_hi = xs.min((1, 2)), xs.max((1, 2))                         # (tx, slices)
    y_lo, y_hi = ys.min((1, 2)), ys.max((1, 2))                         # (ty, slices)
    shape = (grid.tiles_y, grid.tiles_x, grid.slices)                   # cell id order
    lo = np.stack([np.broadcast_to(x_lo[None], shape), np.broadcast_to(y_lo[:, None], shape),
                   np.broadcast_to(-hi_d, shape)], -1).reshape(-1, 3)
    hi = np.stack([np.broadcast_to(x_hi[None], shape), np.broadcast_to(y_hi[:, None], shape),
                   np.broadcast_to(-lo_d, shape)], -1).reshape(-1, 3)
    return lo, hi


def entry_bounds(offsets: np.ndarray, entries: np.ndarray, gpu_lights: np.ndarray,
                 box_lo: np.ndarray, box_hi: np.ndarray) -> np.ndarray:
    """(entries,) float64: each entry's bound, I / (d^2 + 1), with I its light's brightest
    channel of colour x intensity and d the distance from its centre to its cell's box."""
    centre = np.ascontiguousarray(gpu_lights["pos_radius"][:, :3], np.float64)   # a light's, once
    power = np.maximum(gpu_lights["color_cos_inner"][:, :3].max(1).astype(np.float64), 0.0)
    out = np.empty(len(entries), np.float64)
    _entry_bounds(np.asarray(offsets, np.int64), np.asarray(entries, np.int64), centre, power,
                  np.ascontiguousarray(box_lo, np.float64), np.ascontiguousarray(box_hi, np.float64),
                  out)
    return out


@numba.njit(cache=True, nogil=True)
def _entry_bounds(offsets, entries, centre, power, box_lo, box_hi, out):
    """entry_bounds' loop, cell by cell: the float64 operations of the array form it replaced
    (each axis's gap max(lo - c, 0) + max(c - hi, 0), their squares summed x, y, z), so the
    same bounds bit for bit."""
    for c in range(len(offsets) - 1):
        for e in range(offsets[c], offsets[c + 1]):
            i = entries[e]
            d2 = 0.0
            for k in range(3):
                g = max(box_lo[c, k] - centre[i, k], 0.0) + max(centre[i, k] - box_hi[c, k], 0.0)
                d2 += g * g
            out[e] = power[i] / (d2 + 1.0)


def cell_cdf(offsets: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(entries,) uint32: the cumulative masses of every cell's entries (module docstring)
    from their bounds `weights`: the defensive mixture, quantised to integers of which each
    is at least 1 and every cell's sum is MASS_TOTAL (its remainder on its last entry)."""
    offsets = np.asarray(offsets, np.int64)
    counts = np.diff(offsets)
    if int(counts.max(initial=0)) * 2 > MASS_TOTAL:
        raise ValueError(f"a cell list of {int(counts.max())} entries exceeds the sampling "
                         f"masses' resolution (2^{MASS_BITS} units)")
    n = np.repeat(counts, counts).astype(np.float64)
    starts = offsets[:-1][counts > 0]
    total = np.add.reduceat(weights, starts) if len(starts) else np.zeros(0)
    per_cell = np.zeros(len(counts))
    per_cell[counts > 0] = total
    w_sum = np.repeat(per_cell, counts)
    share = np.where(w_sum > 0, weights / np.where(w_sum > 0, w_sum, 1.0), 1.0 / n)
    p = (1.0 - DEFENSIVE) * share + DEFENSIVE / n
    mass = 1 + np.floor(p * (MASS_TOTAL - n)).astype(np.int64)
    used = np.zeros(len(counts), np.int64)
    if len(starts):
        used[counts > 0] = np.add.reduceat(mass, starts)
    last = offsets[1:][counts > 0] - 1
    mass[last] += MASS_TOTAL - used[counts > 0]
    cum = np.cumsum(mass)
    before = np.concatenate([[0], cum])[offsets[:-1]]       # per cell: the mass before it
    return (cum - np.repeat(before, counts)).astype(np.uint32)


def masses(cdf: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(entries,) int64: each entry's mass, from the cumulative words (what the shader reads)."""
    out = np.asarray(cdf, np.int64).copy()
    counts = np.diff(np.asarray(offsets, np.int64))
    not_first = np.ones(len(out), bool)
    not_first[np.asarray(offsets[:-1], np.int64)[counts > 0]] = False
    out[not_first] -= np.asarray(cdf, np.int64)[np.nonzero(not_first)[0] - 1]
    return out


def list_cdf(offsets, entries, gpu_lights, grid: Grid, cam: FrameCamera) -> np.ndarray:
    """The sampling CDF words of a clustered binning (module docstring)."""
    lo, hi = cell_view_boxes(grid, cam)
    return cell_cdf(offsets, entry_bounds(offsets, entries, gpu_lights, lo, hi))


# ---- the GPU's draws, bit for bit (glsl/sampling.glsl), for the cost model's replay -------

def _pcg_step(state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(new state, output) of one PCG RXS-M-XS step over uint32 arrays."""
    state = (state * np.uint32(747796405) + np.uint32(2891336453)).astype(np.uint32)
    word = (((state >> ((state >> np.uint32(28)) + np.uint32(4))) ^ state)
            * np.uint32(277803737)).astype(np.uint32)
    return state, (word >> np.uint32(22)) ^ word


def pcg_hash(v) -> np.ndarray:
    return _pcg_step(np.asarray(v, np.uint32))[1]


def pixel_streams(pixels: np.ndarray, seed: int, frame: int) -> np.ndarray:
    """uint32 states of the pixels' streams (index y * width + x, GL rows: pixel_stream)."""
    with np.errstate(over="ignore"):
        key = pcg_hash(np.uint32(seed) ^ pcg_hash(np.uint32((frame + 0x9E3779B9) & 0xFFFFFFFF)))
        return pcg_hash(np.asarray(pixels, np.uint64).astype(np.uint32) ^ key)


def next_random(state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(new states, 32 random bits) of next_random()."""
    with np.errstate(over="ignore"):
        return _pcg_step(state)


def next_mass(state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    state, bits = next_random(state)
    return state, bits >> np.uint32(32 - MASS_BITS)


def draw_entries(cdf: np.ndarray, first: np.ndarray, count: np.ndarray, u: np.ndarray):
    """glsl/sample_cdf.glsl's draw_entry for arrays of (first, count >= 1, u): (entry, the
    search's probe positions (iterations, lanes) with -1 past a lane's last)."""
    lo = np.asarray(first, np.int64).copy()
    hi = lo + np.asarray(count, np.int64) - 1
    probes = []
    while True:
        active = lo < hi
        if not active.any():
            break
        mid = (lo + hi) >> 1
        below = u < cdf[np.where(active, mid, 0)]
        hi = np.where(active & below, mid, hi)
        lo = np.where(active & ~below, mid + 1, lo)
        probes.append(np.where(active, mid, -1))
    return lo, (np.stack(probes) if probes else np.zeros((0, len(lo)), np.int64))
