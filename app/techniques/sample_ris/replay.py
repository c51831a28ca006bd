"""sample-ris: what the GPU cost model needs (app.model): its candidates passes (named
"shade": the passes that evaluate lights) as the wave replay's segments, with the lights
the GPU draws reproduced bit for bit in numpy uint32 arithmetic (glsl/sampling.glsl's PCG
streams, ris.glsl's rounds, ris_candidates.comp's search of the cell's CDF words): the
draws never depend on a float, so the same integers give the same lights.

Per shading lane and round k of S: one step (k) whose head is the lane's cell record and
whose list is its M drawn lights in draw order (entries[e] then lights[entries[e]], as the
shader fetches them).  Not modelled: the CDF search's log2 n word reads, the resolve pass
(one record read, no evaluation) and the S - 1 further launches of every wave (the model
prices a shading pass's fixed work once a wave); spatial reuse (its neighbours' G-buffer
reads and evaluations) is not replayed: wave_program refuses it.
"""
from __future__ import annotations

import numpy as np

from cpu_prep import sampling

from ...model import waves
from ..blocks import cell_ranges
from ..replay_walks import cell_head

GOLDEN = 0x9E3779B9


def _u32(v) -> np.ndarray:
    return np.asarray(v, np.uint32)


def pcg_hash(v) -> np.ndarray:
    """glsl/sampling.glsl pcg_hash: PCG's RXS-M-XS output of one LCG step (uint32 wrap)."""
    with np.errstate(over="ignore"):
        state = _u32(v) * np.uint32(747796405) + np.uint32(2891336453)
        word = ((state >> ((state >> np.uint32(28)) + np.uint32(4))) ^ state) * np.uint32(277803737)
    return (word >> np.uint32(22)) ^ word


def lcg(state) -> np.ndarray:
    """next_random's state step (its output is pcg_hash of the state before it)."""
    with np.errstate(over="ignore"):
        return _u32(state) * np.uint32(747796405) + np.uint32(2891336453)


def pixel_stream(pixel, seed: int, frame: int) -> np.ndarray:
    """sampling.glsl pixel_stream of GL pixel indices y * w + x."""
    with np.errstate(over="ignore"):
        f = pcg_hash(_u32(seed) ^ pcg_hash(_u32(frame) + np.uint32(GOLDEN)))
    return pcg_hash(_u32(pixel) ^ f)


def round_stream(pixel, seed: int, frame: int, k: int, salt: int = 0) -> np.ndarray:
    """ris.glsl round_stream: the pixel's stream of round k."""
    with np.errstate(over="ignore"):
        r = pcg_hash(np.uint32(k) * np.uint32(GOLDEN) + np.uint32(salt))
    return pcg_hash(pixel_stream(pixel, seed, frame) ^ r)


def drawn_entries(cdf, offsets_counts, cell, pixel, opts) -> np.ndarray:
    """(lanes, S, M) int64: the entry of the cell list each candidate draws (draw_entry: the
    first entry of the cell with u < its CDF word, u = next_random >> 1), per lane of
    `pixel` reading `cell`, round and candidate; each candidate also takes one unit draw
    (accept), which only advances the stream."""
    cdf = np.asarray(cdf, np.int64)
    first = offsets_counts[cell, 0]
    n_cells = len(offsets_counts)
    owner = np.repeat(np.arange(n_cells, dtype=np.int64), offsets_counts[:, 1])
    keys = owner << 32 | cdf                       # ascending: cells in order, words within
    out = np.empty((len(pixel), opts.samples, opts.candidates), np.int64)
    shift = np.uint32(32 - sampling.MASS_BITS)
    for k in range(opts.samples):
        state = round_stream(pixel, opts.sample_seed, opts.sample_frame, k)
        for m in range(opts.candidates):
            u = (pcg_hash(state) >> shift).astype(np.int64)
            state = lcg(lcg(state))                # the mass draw, then accept's unit draw
            out[:, k, m] = np.searchsorted(keys, np.asarray(cell, np.int64) << 32 | u, "right")
    assert (out >= first[:, None, None]).all()
    return out


def wave_program(technique, frame, width):
    opts, b = frame.opts, frame.build
    if opts.spatial_reuse:
        raise NotImplementedError(f"{technique.name}: the replay models spatial reuse off only "
                                  f"(--spatial-reuse {opts.choice_name('spatial_reuse')})")
    prog = waves.Program(frame, width)
    ranges = cell_ranges(b)
    lanes = np.nonzero(frame.shading)[0]
    lanes = lanes[ranges[frame.cell[lanes], 1] > 0]          # an empty cell draws nothing
    cell = frame.cell[lanes]
    e = drawn_entries(b.buffers["sample_cdf"], ranges, cell, lanes, opts)
    entries = np.asarray(b.buffers["entries"], np.int64)
    lid = prog.add_list(entries[e.ravel()], entry_off=4 * e.ravel(), entry_buf="entries")
    m, s = opts.candidates, opts.samples
    head = cell_head(prog, lanes)
    for k in range(s):
        first = (np.arange(len(lanes), dtype=np.int64) * s + k) * m
        prog.add(lanes, step=k, head=head, lights=(lid, first, m, False))
    return prog
