"""brute: what the GPU cost model needs (app.model): the shading pass as the wave replay's
segments (wave_program) and the figures of the passes before it (cull_figures)."""
from __future__ import annotations

import numpy as np

from ...model import waves
from ..replay_walks import add_all_lights


def wave_program(technique, frame, width):
    prog = waves.Program(frame, width)
    add_all_lights(prog, np.nonzero(frame.shading)[0])     # wave-uniform tests
    return prog
