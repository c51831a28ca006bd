"""Sampling against culling on one frame (app.bench.sampling): a sampler's error against brute
is above 0 and falls as S grows, an exact technique's is 0, a sample-list pixel some light
affects evaluates exactly S lights, and the bins the crossover reads add up to the frame."""
import json

import numpy as np
import pytest

from app.bench import sampling
from app.bench.caps import dropped_lights
from app.bench.presets import FULL, GPU_CHECK, QUICK
from app.techniques import REGISTRY
from tests.helpers import make_scene, random_lights

SIZE = (96, 64)
S = (1, 4, 16)
SEEDS = 4
REPEAT, HEAVY = 3, 60.0


@pytest.fixture(scope="module")
def rows(gl):
    from app.pipeline.renderer import Renderer
    rng = np.random.default_rng(5)
    scene = make_scene(random_lights(rng, 80, (-10.0, 0.0, -30.0), (10.0, 6.0, 5.0),
                                     radius=(3.0, 12.0)), size=SIZE)
    c = sampling.SamplingConfig(("test",), 80, SIZE, S, seeds=SEEDS, repeat=REPEAT, flip=False,
                                model=False, heavy_eval_pp=HEAVY, heavy_repeat=1)
    keep = {"brute", "tiled", "clustered"}
    configs = [cfg for cfg in sampling.configurations(S, dropped_lights(scene, SIZE, 0, 64))
               if cfg["technique"] in keep and cfg["kind"] == "exact" or cfg["policy"] == "urp-16"
               or cfg["technique"] == "sample-list"]
    with Renderer(scene, SIZE) as r:
        got = sampling.run_frame(r, scene.lights_at(0, 64), configs, c, log=open("/dev/null", "w"))
    return got


def _by(rows, **kw):
    return [r for r in rows if all(r[k] == v for k, v in kw.items())]


def test_samplers_err_exact_techniques_do_not(rows):
    assert REGISTRY["sample-list"].role == "sampler"
    exact = _by(rows, kind="exact")
    assert {r["technique"] for r in exact} == {"brute", "tiled", "clustered"}
    assert all(r["image_error"] == 0 and r["mismatch_count"] == 0 for r in exact)
    samplers = _by(rows, kind="sampler")
    assert [r["samples_per_pixel"] for r in samplers] == list(S)
    assert all(r["image_error_min"] > 0 and r["seeds"] == SEEDS for r in samplers)
    assert all(len(json.loads(r["seed_errors"])) == SEEDS for r in samplers)
    # the support pass's light set is brute's at every pixel
    assert all(r["mismatch_count"] == 0 for r in samplers)


def test_a_binding_cap_errs_and_tests_fewer_lights(rows):
    cap, = _by(rows, kind="cap")
    brute, = _by(rows, technique="brute")
    assert cap["capped_lights"] > 0 and cap["image_error"] > 0 and cap["mismatch_count"] > 0
    assert cap["shadow_pp"] < brute["shadow_pp"] == brute["exact_pp"]


def test_error_falls_as_s_grows(rows):
    errs = [r["image_error"] for r in _by(rows, kind="sampler")]
    assert errs[0] > errs[1] > errs[2]
    # variance ~ 1/S: 16x the samples at least halves the error over these seeds
    assert errs[2] < 0.5 * errs[0]


def test_sample_list_evaluates_s_lights_where_a_light_affects(rows):
    for r in _by(rows, kind="sampler"):
        assert r["evaluated_lit_pp"] == pytest.approx(r["samples_per_pixel"], abs=1e-9)
        assert 0 < r["evaluated_pp"] <= r["samples_per_pixel"]
        # its shadow tests: at most its draws at lit pixels, never more than its evaluations
        assert r["shadow_bound"] == 1 and 0 < r["shadow_pp"] <= r["evaluated_pp"]


def test_a_replayed_sampler_counts_its_affecting_draws(gl):
    """With the model on, a sampler's shadow tests are its draws that hit an affecting light
    (its replay's), fewer than its draws at lit pixels; a culling technique's its own
    contrib_count."""
    from app.pipeline.renderer import Renderer
    rng = np.random.default_rng(7)
    scene = make_scene(random_lights(rng, 60, (-10.0, 0.0, -30.0), (10.0, 6.0, 5.0),
                                     radius=(2.0, 8.0)), size=SIZE)
    c = sampling.SamplingConfig(("test",), 60, SIZE, (4,), seeds=2, repeat=1, flip=False,
                                model=True, heavy_eval_pp=HEAVY, heavy_repeat=1)
    configs = [cfg for cfg in sampling.configurations((4,), {})
               if cfg["technique"] in ("sample-list", "clustered")]
    with Renderer(scene, SIZE) as r:
        got = sampling.run_frame(r, scene.lights_at(0, 64), configs, c, log=open("/dev/null", "w"))
    sampler, = _by(got, kind="sampler")
    exact, = _by(got, technique="clustered")
    assert sampler["shadow_bound"] == 0 and sampler["model_lighting_ms"] > 0
    assert 0 < sampler["shadow_pp"] < sampler["evaluated_pp"]
    assert exact["shadow_pp"] == exact["exact_pp"] and exact["shadow_bound"] == 0


def test_the_bins_add_up_to_the_frame_error(rows):
    for r in _by(rows, kind="sampler") + _by(rows, kind="cap"):
        b = json.loads(r["bins"])
        assert b["lo"][0] == 1 and all(h + 1 == lo for h, lo in zip(b["hi"], b["lo"][1:]))
        assert sum(b["pixels"]) <= b["geometry"]
        whole = [np.sqrt(np.dot(b["pixels"], np.square(e)) / b["geometry"]) for e in b["err"]]
        assert whole == pytest.approx(json.loads(r["seed_errors"]), rel=1e-4, abs=1e-6)


def test_the_presets_size_the_study():
    quick, full = QUICK.config("sampling"), FULL.config("sampling")
    assert len(quick.scenes) == 2 and quick.seeds == 4 and quick.samples == (1, 4, 16, 64)
    assert "stress" in full.scenes and full.seeds == 8 and max(full.samples) == 64
    assert full.samples == (1, 2, 4, 8, 16, 32, 64)
    assert GPU_CHECK.config("sampling").scenes == ()
    for preset in (QUICK, FULL):
        assert preset.config("sampling").replay_budget == preset.config("rendered").replay_budget


def test_a_count_falls_in_its_power_of_two_bin():
    counts = np.array([1, 2, 3, 4, 7, 8, 1023, 1024])
    assert sampling.bin_index(counts).tolist() == [0, 1, 1, 2, 2, 3, 9, 10]
    bins = sampling.count_bins(counts)
    assert bins[0] == (1, 1) and bins[-1] == (1024, 2047) and len(bins) == 11


def test_no_scenes_writes_no_file(tmp_path):
    (tmp_path / sampling.CSV).write_text("stale")
    c = sampling.SamplingConfig((), 64, SIZE, S, seeds=SEEDS, repeat=1)
    assert sampling.sampling_series(c, tmp_path) == []
    assert not (tmp_path / sampling.CSV).exists()


def test_the_study_writes_the_file_the_report_reads():
    from app.report import sampling as report
    assert sampling.CSV == report.CSV


def test_the_temporal_series_draws_a_sampler_anew_every_frame(gl):
    """A still scene and camera: every exact technique's frames do not change (temporal error
    0), a sampler's do, by its draw alone (sample_frame = the frame), and it never pops."""
    from app.bench import temporal
    kinds = {c["config"]: c["kind"] for c in temporal.configurations(())}
    assert kinds["sample-list"] == "sampler" and kinds["brute"] == "technique"
    rng = np.random.default_rng(8)
    scene = make_scene(random_lights(rng, 40, (-10.0, 0.0, -30.0), (10.0, 6.0, 5.0),
                                     radius=(3.0, 12.0)), size=(64, 36))
    still = scene.camera_at(0, 64)
    scene.camera_at = lambda k, n: still
    rows = temporal.run_temporal(scene, "test", (64, 36), 3, 64, (), log=open("/dev/null", "w"))
    later = [r for r in rows if r["frame"] > 0]
    exact = [r for r in later if r["kind"] == "technique"]
    drawn = [r for r in later if r["kind"] == "sampler"]
    assert exact and all(r["temporal_error_pct"] == 0 and r["changed_pixels"] == 0 for r in exact)
    assert drawn and all(r["temporal_error_pct"] > 0 and r["popping_pixels"] == 0 for r in drawn)



def test_a_heavy_configuration_takes_fewer_timing_samples(rows):
    """brute evaluates every light (80 a pixel, above the fixture's HEAVY): one sample."""
    brute, = _by(rows, technique="brute")
    clustered, = _by(rows, technique="clustered")
    assert brute["evaluated_pp"] > HEAVY > clustered["evaluated_pp"]
    assert brute["timing_samples"] == 1 and clustered["timing_samples"] == REPEAT
    assert all(r["timing_samples"] == SEEDS for r in _by(rows, kind="sampler"))
