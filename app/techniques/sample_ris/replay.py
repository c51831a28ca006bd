"""sample-ris: what the GPU cost model needs (app.model): its candidates passes (named
"shade": the passes that evaluate lights) as the wave replay's segments, with the lights
the GPU draws reproduced bit for bit in numpy uint32 arithmetic (glsl/sampling.glsl's PCG
streams, ris.glsl's rounds, glsl/sample_cdf.glsl's search of the cell's CDF words): the
draws never depend on a float, so the same integers give the same lights.

Per round k of S (a dispatch each), per shading lane: its cell record, then its M draws,
each its search probes of the CDF words and its light (replay_walks.add_cdf_draws), the
rounds' steps one after another.  Not modelled: the resolve pass (one record read, no
evaluation) and the S - 1 further launches of every wave (the model prices a shading pass's
fixed work once a wave); spatial reuse (its neighbours' G-buffer reads and evaluations) is
not replayed: wave_program refuses it.
"""
from __future__ import annotations

import numpy as np

from cpu_prep import sampling

from ...model import waves
from ..replay_walks import add_cdf_draws, entry_list, listed_lanes

GOLDEN = 0x9E3779B9


def round_masses(pixel, opts, k: int, salt: int = 0) -> list[np.ndarray]:
    """The u of each of round k's M candidate draws (ris.glsl round_stream, then per
    candidate next_mass and accept's unit draw, which only advances the stream)."""
    with np.errstate(over="ignore"):
        r = sampling.pcg_hash(np.uint32(k) * np.uint32(GOLDEN) + np.uint32(salt))
        state = sampling.pcg_hash(sampling.pixel_streams(pixel, opts.sample_seed, opts.sample_frame) ^ r)
    out = []
    for _ in range(opts.candidates):
        state, u = sampling.next_mass(state)
        state, _ = sampling.next_random(state)
        out.append(u)
    return out


def wave_program(technique, frame, width):
    opts = frame.opts
    if opts.spatial_reuse:
        raise NotImplementedError(f"{technique.name}: the replay models spatial reuse off only "
                                  f"(--spatial-reuse {opts.choice_name('spatial_reuse')})")
    prog = waves.Program(frame, width)
    lid = entry_list(prog, frame.build.buffers["entries"])
    step = 0
    for k in range(opts.light_samples):        # a round a dispatch: its cell record, M draws
        lanes, first, count = listed_lanes(prog, frame, step)
        step = add_cdf_draws(prog, lanes, first, count, lambda: round_masses(lanes, opts, k), lid,
                             step + 1, key=("sample-ris", k))
    return prog
