"""Stochastic light culling in the light cutoff study: the quick plan's few extra jobs (each
cutoff scene, STOCHASTIC_BUDGETS x STOCHASTIC_TECHNIQUES, one draw) and the report's sentence
beside the cutoff level of the same t."""
from app.bench.cutoff import STOCHASTIC_BUDGETS, STOCHASTIC_TECHNIQUES, stochastic_draw
from app.bench.plan import plan
from app.bench.presets import QUICK
from app.report.cutoff import _stochastic_finding, stochastic_budget


def test_the_quick_plan_adds_a_few_stochastic_jobs_to_the_cutoff_study():
    jobs = plan(QUICK.config("rendered"), lambda scene, counts: tuple(counts))
    stoch = [j for j in jobs if stochastic_draw(j.opts)]
    assert len(stoch) == len(QUICK.config("rendered").cutoff_scenes) * len(STOCHASTIC_BUDGETS) * len(STOCHASTIC_TECHNIQUES)
    for j in stoch:
        assert j.study == "cutoff" and j.cutoff == 0 and j.technique in STOCHASTIC_TECHNIQUES
        assert stochastic_draw(j.opts) == (j.opts.stochastic, 0, 0)
        assert f"stochastic t=1/{j.opts.stochastic}" in j.describe()
    assert {j.opts.stochastic for j in stoch} == set(STOCHASTIC_BUDGETS)
    # nothing else of the plan draws
    assert all(j.study == "cutoff" for j in jobs if stochastic_draw(j.opts))


def test_the_report_sets_each_budget_beside_the_cutoff_of_the_same_t():
    row = lambda t, cut, stoch, err, cost: {"technique": t, "cutoff": cut, "stochastic": stoch,
                                            "image_error": err, "frame_cost_ms": cost,
                                            "radiance_ratio": 0.9}
    stoch = [row("tiled", 0, 256, 0.5, 2.0), row("clustered", 0, 256, 0.4, 1.0)]
    bounded = [row("tiled", 256, 0, 1.0, 1.0), row("clustered", 256, 0, 1.0, 0.5),
               row("brute", 256, 0, 1.0, 9.0)]
    assert stochastic_budget(stoch[0]) == 256 and stochastic_budget({"stochastic": float("nan")}) == 0
    text = _stochastic_finding(stoch, bounded)
    assert text.startswith(" Stochastic culling (one draw) has error 0.45 at t=1/256")
    assert "the cutoff at t=1/256: 1, at 2x its cost for clustered, tiled" in text
    assert _stochastic_finding([], bounded) == ""
