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


# counted steps as app.model.counts gives them: (alu, trans, idiv, wred)
OPS = {"light": [15, 0, 0, 0], "test:point": [8, 0, 0, 0], "shade:point": [64, 5, 0, 0],
       "ggx": [88, 9, 0, 0], "wave": [94, 0, 0, 0]}


def figures(width: int, **loops) -> waves.Figures:
    f = waves.Figures(width=width, waves=1000, busy_waves=1000, pixels=64000, shading_pixels=64000,
                      ops=dict(OPS))
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
    fixed = a.waves * cost.slots(OPS["wave"], g) * 32 / (g.units * g.lanes * g.clock_ghz * 1e9)
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


def test_slots_price_the_counted_columns_by_the_named_assumptions():
    g = cost.BY_KEY["gtx980"]                       # sfu 1/4: a transcendental is 4 slots
    assert cost.slots([10, 1, 0, 0], g) == pytest.approx(14)
    div = cost.ASSUMED["int_division"].value
    assert cost.slots([0, 0, 1, 0], g) == pytest.approx(div + 4)
    assert cost.slots([0, 0, 0, 1], g) == pytest.approx(cost.ASSUMED["wave_reduction"].value)
    with cost.assume(int_division=2 * div):
        assert cost.slots([0, 0, 1, 0], g) == pytest.approx(2 * div + 4)
    assert cost.slots([0, 0, 1, 0], g) == pytest.approx(div + 4)     # restored


@pytest.mark.parametrize("name", sorted(cost.ASSUMED))
def test_every_assumption_moves_some_limit(name):
    """Each named assumption is read by the model: moving it changes a pass's time."""
    g = cost.BY_KEY["rx480"]
    f = figures(64, light={"issued": 10**6, "vector_loads": 10**6, "vector_lines": 10**7})
    f.ops["light"] = [15, 1, 1, 1]
    f.unique_bytes = {"lights": 10**9}
    before = cost.times(f, g)
    with cost.assume(**{name: cost.ASSUMED[name].value * 1.3}):
        after = cost.times(f, g)
    assert before != after, name


def test_a_step_the_pass_runs_must_be_counted():
    """A loop kind the replay issued that the pass's program prices nowhere is an error, not
    a free step."""
    f = figures(32, node={"issued": 100})
    with pytest.raises(ValueError, match="prices no such step"):
        cost.instructions(f, cost.BY_KEY["gtx980"])


def test_figures_round_trip_through_their_dict():
    """A row's waves column holds everything the model reads: the same times from it."""
    f = figures(32, light={"issued": 12345, "vector_loads": 2000, "vector_lines": 3000})
    f.tested[0], f.shaded[0], f.specular = 500, 200, 50
    f.unique_bytes = {"lights": 9600, "entries": 640}
    back = waves.Figures.from_dict(f.as_dict())
    for g in cost.GPUS:
        if g.wave == 32:
            assert cost.times(back, g) == pytest.approx(cost.times(f, g))
