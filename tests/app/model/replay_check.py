"""The wave replay's check against a rendered frame, shared by the replay's tests
(tests/app/model/test_waves.py) and the tree options' (tests/app/techniques/
test_tree_options.py): the replay's per-pixel lights evaluated and nodes visited equal the
shader's counters, its affecting lights contrib_count's up to the float32 rounding of its
copy of the affects test (a sampler's: within its support)."""
from __future__ import annotations

import numpy as np

from app.model import waves
from app.techniques import REGISTRY, parts


def gl_order(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a[::-1]).ravel()


def check(renderer, name: str, opts: dict, width: int, where: str) -> waves.Replay:
    tech = REGISTRY[name]
    res = renderer.render(tech, 0, opts)
    fr = waves.frame_data(renderer, res, tech.resolve_options(opts))
    rp = waves.replay(parts.wave_program(tech, fr, width))
    what = f"{where} {name} {opts} W={width}"
    ev, nodes = gl_order(res.evaluated), gl_order(res.nodes)
    bad = np.nonzero(rp.evaluated != ev)[0]
    assert not len(bad), (f"{what}: evaluated differs at {len(bad)} pixels, first {bad[0]}: "
                          f"replay {rp.evaluated[bad[0]]}, shader {ev[bad[0]]}")
    bad = np.nonzero(rp.nodes != nodes)[0]
    assert not len(bad), (f"{what}: nodes differ at {len(bad)} pixels, first {bad[0]}: "
                          f"replay {rp.nodes[bad[0]]}, shader {nodes[bad[0]]}")
    # the CPU's float32 copy of the affects test may round the other way at a boundary
    if tech.role == "sampler":
        # its contrib_count is its support's (all it can draw), its pass shades S draws: a
        # pixel the replay finds a hit at has a support
        support = gl_order(res.contrib_count)
        differ = int(((rp.contrib > 0) & (support == 0)).sum())
    else:
        differ = int((rp.contrib != gl_order(res.contrib_count)).sum())
    assert differ <= max(1, ev.size // 1000), f"{what}: contrib differs at {differ} pixels"
    assert int(res.contrib_count.sum()) > 0, f"{what}: no light affects any pixel"
    return rp
