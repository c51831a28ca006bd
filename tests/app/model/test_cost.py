"""The GPU cost model (app/model/cost.py): its constants agree with the vendors' own headline
figures, and each limit responds to the figure it is made of, and only to it."""
from __future__ import annotations

import numpy as np
import pytest

from app.model import cost, waves
from app.model.waves import FIELDS, KINDS

# FP32 TFLOPS the vendors publish (at the clocks the model uses: boost, PS4's fixed clock)
PUBLISHED_TFLOPS = {"gtx980": 4.98, "rx480": 5.83, "ps4": 1.84, "h200": 66.9}


@pytest.mark.parametrize("gpu", cost.GPUS, ids=lambda g: g.key)
def test_constants_give_the_published_peak(gpu):
    tflops = 2 * gpu.units * gpu.lanes * gpu.clock_ghz / 1e3
    assert tflops == pytest.approx(PUBLISHED_TFLOPS[gpu.key], rel=0.01)
    assert gpu.wave in waves.WIDTHS and 0 < gpu.sfu <= 1 and gpu.graphics_units <= gpu.units


def figures(width: int, **loops) -> waves.Figures:
    f = waves.Figures(width=width, waves=1000, busy_waves=1000, pixels=64000, shading_pixels=64000)
    for kind, vals in loops.items():
        for name, v in vals.items():
            f.loops[KINDS.index(kind), FIELDS.index(name)] = v
    return f


def test_alu_time_follows_issued_iterations():
    g = cost.BY_KEY["gtx980"]
    a = figures(32, light={"issued": 10**6})
    b = figures(32, light={"issued": 2 * 10**6})
    a.tested[0] = b.tested[0] = 0
    ta, tb = cost.times(a, g)["alu"], cost.times(b, g)["alu"]
    fixed = a.waves * cost.WAVE[0] * 32 / (g.units * g.lanes * g.clock_ghz * 1e9)
    assert tb - fixed == pytest.approx(2 * (ta - fixed))
    # a light iteration that affects a lane pays the shading code on top of the test
    c = figures(32, light={"issued": 10**6})
    c.tested[0], c.shaded[0] = 10**6, 10**6
    assert cost.instructions(c, g) > cost.instructions(a, g)


def test_scalar_loads_cost_only_where_there_is_no_scalar_unit():
    loads = {"issued": 10**5, "scalar_loads": 10**5, "scalar_lines": 2 * 10**5}
    gcn, nv = cost.BY_KEY["rx480"], cost.BY_KEY["gtx980"]
    assert gcn.scalar_unit and not nv.scalar_unit
    assert cost.times(figures(64, light=loads), gcn)["l1"] == 0.0
    assert cost.times(figures(32, light=loads), nv)["l1"] > 0.0


def test_vector_loads_are_bound_by_addresses_or_lines():
    g = cost.BY_KEY["rx480"]          # 16 addresses a clock: a wave64 load takes 4 clocks
    coherent = figures(64, light={"issued": 1000, "vector_loads": 1000, "vector_lines": 1000})
    scattered = figures(64, light={"issued": 1000, "vector_loads": 1000, "vector_lines": 64000})
    hz = g.clock_ghz * 1e9 * g.units
    assert cost.times(coherent, g)["l1"] == pytest.approx(1000 * 4 / hz)
    assert cost.times(scattered, g)["l1"] == pytest.approx(64000 / hz)   # one 64-B line a clock


def test_dram_counts_each_line_once_and_the_pixels():
    g = cost.BY_KEY["ps4"]
    f = figures(64)
    f.unique_bytes = {"lights": 96 * 1024}
    assert cost.times(f, g)["dram"] == pytest.approx((96 * 1024 + 64000 * cost.PIXEL_BYTES) / 176e9)


def test_a_pass_takes_its_slowest_limit_and_says_which():
    g = cost.BY_KEY["h200"]
    f = figures(32, light={"issued": 10**7})
    t = cost.times(f, g)
    assert cost.pass_ms(f, g) == pytest.approx(1e3 * max(t.values()))
    assert cost.bound(f, g) == "alu"
    with pytest.raises(ValueError, match="32-lane"):
        cost.times(f, cost.BY_KEY["ps4"])
