"""What a per-tile capped frame must show (HDRP FPTL's hdrp-fptl-24 / -63, cpu_prep.caps
per_tile), computed on the CPU, for the exactness check (app.exactness).

    perfect (the floor technique: each pixel's exact light list, evaluate_light's own
    decisions, untimed)  ->  (pixel, light) entries, checked against brute's count and hash
      -> per 16x16 tile the lights some pixel of it meets: the tile's fine-pruned list
      -> caps.tile_keep on those (tile, light) pairs: each category's lowest HDRP sort keys
      -> per pixel the count and hash of its entries the tile kept

A capped fptl frame must equal that at every pixel; the check can fail both ways (a light
the cap should have kept and did not, or one it should have dropped), because nothing of
fptl's own lists or counters is read here.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cpu_prep import caps

from .dump import mix


@dataclass
class Expected:
    """Per pixel (image order, row 0 = top) what brute shows and what the cap leaves."""
    full_count: np.ndarray       # (H, W) uint32: every light at the pixel (brute's)
    full_hash: np.ndarray
    count: np.ndarray            # (H, W) uint32: the lights its tile kept
    hash: np.ndarray
    lights: int                  # lights dropped from some tile
    entries: int                 # (tile, light) list entries dropped
    tiles: int                   # tiles that dropped one
    pixel: np.ndarray            # (E,) the entries' pixels, GL linear (y * W + x)
    ids: np.ndarray              # (E,) their scene ids
    kept: np.ndarray             # (E,) bool

    def kept_ids(self, x: int, row: int, height: int, width: int) -> list[int]:
        """Scene ids the cap keeps at pixel (x, row from the top)."""
        at = self.pixel == (height - 1 - row) * width + x
        return sorted(self.ids[at & self.kept].tolist())


def pixel_entries(renderer, render_args: dict, draw: dict):
    """(pixels GL linear, scene ids) of every (pixel, light) pair that affects: perfect's
    lists of the frame `render_args` describes (frame, frames, lights), with the stochastic
    draw `draw` (its options; {} when off)."""
    from .techniques import with_role
    floor = with_role("floor")
    args = {k: v for k, v in render_args.items() if k != "opts"}
    res = renderer.render(floor, opts=dict(draw) or None, **args)
    pixels, ids, first = [], [], 0
    # perfect's bands, each its ranges and entries (its stat "bands" counts fill dispatches)
    bands = sum(1 for name in renderer.provided() if name.startswith("perfect_ranges_"))
    for k in range(bands):
        ranges = renderer.read(f"perfect_ranges_{k}").reshape(-1, 2).astype(np.int64)
        entries = renderer.read(f"perfect_entries_{k}").astype(np.int64)
        pixels.append(first + np.repeat(np.arange(len(ranges)), ranges[:, 1]))
        ids.append(res.build.lights.ids[entries[_ranges_index(ranges)]].astype(np.int64))
        first += len(ranges)
    cat = lambda parts: np.concatenate(parts) if parts else np.zeros(0, np.int64)
    return cat(pixels), cat(ids)


def _ranges_index(ranges: np.ndarray) -> np.ndarray:
    """The entry positions of (first, count) ranges, in range order."""
    count = ranges[:, 1]
    starts = np.repeat(ranges[:, 0] - np.concatenate([[0], np.cumsum(count)[:-1]]), count)
    return starts + np.arange(int(count.sum()))


def figures(pixel: np.ndarray, ids: np.ndarray, keep: np.ndarray, size) -> tuple[np.ndarray, np.ndarray]:
    """(count, hash) per pixel, image order, of the entries `keep` selects (the dump's
    contrib_count / contrib_hash)."""
    w, h = size
    p, hashed = pixel[keep], mix(ids[keep].astype(np.uint32))
    count = np.bincount(p, minlength=w * h).astype(np.uint32)
    out = np.zeros(w * h, np.uint32)
    if len(p):
        order = np.argsort(p, kind="stable")
        p, hashed = p[order], hashed[order]
        first = np.flatnonzero(np.r_[True, p[1:] != p[:-1]])
        out[p[first]] = np.bitwise_xor.reduceat(hashed, first)
    flip = lambda a: a.reshape(h, w)[::-1]
    return flip(count), flip(out)


def expected(renderer, result, render_args: dict, draw: dict) -> Expected:
    """The per-pixel figures the capped frame `result` (fptl's, cap policy in its stats) must
    show: perfect's entries less those its tile's cap drops (caps.tile_keep over the tile's
    lights, on fptl's grid of TILE-pixel tiles, GL origin bottom left)."""
    policy = result.meta["stats"]["cap_policy"]
    grid = result.build.grid
    w, h = renderer.size
    pixel, ids = pixel_entries(renderer, render_args, draw)
    tile = (pixel // w // grid.tile) * grid.tiles_x + (pixel % w) // grid.tile
    n = max(len(result.build.frame.lights), 1)
    pairs, inverse = np.unique(tile * n + ids, return_inverse=True)
    types = result.build.frame.lights["type"][pairs % n]
    kept_pair = caps.tile_keep(policy, pairs // n, types, pairs % n)
    kept = kept_pair[inverse.ravel()]
    every = np.ones(len(ids), bool)
    full = figures(pixel, ids, every, (w, h))
    capped = figures(pixel, ids, kept, (w, h))
    return Expected(*full, *capped, lights=len(np.unique(pairs[~kept_pair] % n)),
                    entries=int((~kept_pair).sum()), tiles=len(np.unique(pairs[~kept_pair] // n)),
                    pixel=pixel, ids=ids, kept=kept)


__all__ = ["Expected", "expected", "pixel_entries", "figures"]
