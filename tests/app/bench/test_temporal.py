"""Temporal stability along a moving path (app.bench.temporal, app.report.temporal): the
temporal error and popping of every exact technique, cap policy and cutoff level against the
unbounded reference; exact techniques never pop, a cap that binds on moving lights does."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from app.bench import temporal
from app.bench.cutoff import STOCHASTIC_BUDGETS
from app.bench.presets import FULL, GPU_CHECK, QUICK
from scenes.motion import Motion
from tests.helpers import make_scene, random_lights


def _frame(image, hashes):
    return SimpleNamespace(image=np.asarray(image, np.float32).reshape(1, -1, 1).repeat(3, 2),
                           contrib_hash=np.asarray(hashes, np.uint32).reshape(1, -1))


def test_popping_is_a_set_change_where_the_exact_set_stays():
    covered = np.ones((1, 4), bool)
    exact0, exact1 = _frame([1, 1, 1, 1], [1, 2, 3, 4]), _frame([1, 1, 1, 1], [1, 2, 3, 9])
    t0, t1 = _frame([1, 1, 1, 1], [1, 2, 3, 4]), _frame([1, 2, 1, 1], [5, 2, 3, 7])
    ref0, ref1 = _frame([2, 2, 2, 2], [0] * 4), _frame([2, 3, 2, 2], [0] * 4)
    f = temporal.temporal_figures(t1, t0, ref1, ref0, exact1, exact0, covered)
    # pixel 0 changed set, exact did not: a pop; pixel 3 changed with the exact set: no pop
    assert f["changed_pixels"] == 2 and f["popping_pixels"] == 1
    # dT = dR at every pixel (pixel 1 both +1): no temporal error
    assert f["temporal_error_pct"] == 0.0
    f = temporal.temporal_figures(t0, t0, ref1, ref0, exact0, exact0, covered)
    assert f["temporal_error_pct"] == pytest.approx(100 * (1 / 4) / 2.25)


def test_the_series_writes_the_file_the_report_reads():
    from app.report import temporal as report
    assert temporal.CSV == report.CSV


def test_the_quick_preset_runs_a_small_series_and_the_full_a_larger():
    quick, full = QUICK.config("temporal"), FULL.config("temporal")
    assert 2 <= quick.frames <= 8 and quick.size[0] * quick.size[1] <= 128 * 72
    assert full.frames > quick.frames and GPU_CHECK.config("temporal").frames == 0


def test_exact_techniques_never_pop_and_a_binding_cap_does(gl, tmp_path):
    rng = np.random.default_rng(21)
    lo, hi = (-10.0, 0.0, -30.0), (10.0, 6.0, 5.0)
    scene = make_scene(random_lights(rng, 60, lo, hi, radius=(2.0, 8.0)), size=(64, 36))
    scene.motion = Motion("bounce", 30.0, 1, lo, hi)
    rows = temporal.run_temporal(scene, "test", (64, 36), 3, 64, (256,), log=open("/dev/null", "w"))
    later = [r for r in rows if r["frame"] > 0]
    exact = [r for r in later if r["kind"] == "technique"]
    assert exact and all(r["popping_pixels"] == 0 for r in exact)
    assert sum(r["changed_pixels"] for r in exact) > 0, "no light set changed: test is void"
    urp16 = [r for r in later if r["policy"] == "urp-16"]
    assert all(r["visible"] == 16 and r["capped_lights"] > 0 for r in urp16)
    assert sum(r["popping_pixels"] for r in urp16) > 0
    # stochastic culling: a new draw a frame, so its sets change where the exact ones stay
    for n in STOCHASTIC_BUDGETS:
        drawn = [r for r in later if r["kind"] == "stochastic" and r["stochastic"] == n]
        assert len(drawn) == 2 and all(r["technique"] == "brute" for r in drawn)
        assert sum(r["popping_pixels"] for r in drawn) > 0
        assert all(r["temporal_error_pct"] > 0 for r in drawn)
    assert all(not math.isnan(r["temporal_error_pct"]) for r in later)
    assert all(math.isnan(r["temporal_error_pct"]) for r in rows if r["frame"] == 0)
    # the report's section: its figure and its sentences from these rows
    from app.report.common import Colors, Roles
    from app.report.temporal import fig_temporal
    roles = Roles.from_registry()
    png, text = fig_temporal(rows, tmp_path, Colors([r["technique"] for r in rows], roles), roles)
    assert (tmp_path / png).is_file() and "pop on 0 pixels" in text[0]
    assert any(t.startswith("Cap policies: ") and "urp-16" in t for t in text)
    assert any(t.startswith("Stochastic light culling, a new draw every frame: stochastic 1/")
               for t in text)
