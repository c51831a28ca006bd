"""The sweep interleaves the timing samples of configurations that are compared with each
other, so a drift of the machine falls on all of them alike (app/bench/sweep.py)."""
from types import SimpleNamespace

import numpy as np

from app.bench.plan import Job, plan
from app.bench.presets import PRESETS
from app.bench.sweep import Sweep, compared_groups
from app.techniques import REGISTRY


def test_groups_are_one_study_scene_light_count_and_frame():
    jobs = plan(PRESETS["quick"].config("rendered"), lambda scene, counts: tuple(counts))
    groups = compared_groups(jobs)
    assert sum(len(g) for g in groups) == len(jobs)
    assert [j for g in groups for j in g] == jobs                      # order kept
    for g in groups:
        assert len({(j.study, j.scene, j.lights, j.frame) for j in g}) == 1
    keys = [(g[0].study, g[0].scene, g[0].lights, g[0].frame) for g in groups]
    assert len(keys) == len(set(keys))                                  # each group whole
    path = [g for g in groups if g[0].study == "path"]
    assert all({j.technique for j in g} == set(REGISTRY) for g in path)


class Recording(Sweep):
    """Renders nothing: records the order of the timing renders."""

    def __init__(self, wants):
        super().__init__(PRESETS["quick"], log=SimpleNamespace(write=lambda s: None, flush=lambda: None))
        self.wants, self.calls = wants, []

    def scene(self, name, lights):
        return None

    def first_render(self, renderer, job):
        warm = [{"cpu_ms": {}, "gpu_ms": {"gbuffer": 1.0, "shade": 1.0}}] if job.frame else []
        return {"technique": job.technique}, warm, self.wants[job.technique]

    def render(self, renderer, job, readback, samples=1):
        self.calls.append(job.technique)
        return SimpleNamespace(meta={"cpu_ms": {"cull": 1.0}, "gpu_ms": {"gbuffer": 1.0, "shade": 2.0},
                                     "setup_ms": {}})


def test_samples_are_taken_in_rounds():
    sweep = Recording({"a": 3, "b": 3, "c": 2})
    opts = REGISTRY["brute"].Options()
    group = [Job("path", "arena", 64, 0, t, opts) for t in "abc"]
    sweep.measure_group(SimpleNamespace(scene=None), group, 1, 3)
    assert sweep.calls == ["a", "b", "c", "a", "b", "c", "a", "b"]     # c wants 2 (heavy)
    assert [r["samples"] for r in sweep.rows] == [3, 3, 2]


def test_a_warm_read_back_render_counts_as_a_sample():
    sweep = Recording({"a": 3, "b": 3})
    opts = REGISTRY["brute"].Options()
    group = [Job("path", "arena", 64, 1, t, opts) for t in "ab"]
    sweep.measure_group(SimpleNamespace(scene=None), group, 1, 2)
    assert sweep.calls == ["a", "b", "a", "b"]
    assert [r["samples"] for r in sweep.rows] == [3, 3]


class FirstRenders(Sweep):
    """The real first_render over fake frames: the warm-up rule and the heavy sample count."""

    def __init__(self, evaluated):
        super().__init__(PRESETS["quick"], log=SimpleNamespace(write=lambda s: None, flush=lambda: None))
        self.evaluated, self.renders = evaluated, []

    def lights_for(self, job):
        return np.zeros(4, [("type", np.uint8)])

    def render(self, renderer, job, readback, samples=1):
        self.renders.append(job)
        return SimpleNamespace(meta={"cpu_ms": {"cull": 1.0}, "gpu_ms": {"gbuffer": 1.0, "shade": 2.0}},
                               depth=np.ones((2, 2)), evaluated=np.full((2, 2), self.evaluated))

    def keep_maps(self, job, res, renderer=None):
        pass

    def model_cells(self, renderer, job, res):
        return {}

    def row(self, job, res, renderer):
        return {"study": job.study, "mismatch_count": 0, "figure": len(self.renders)}


def test_the_first_render_of_a_configurations_programs_is_no_sample():
    p, repeat = PRESETS["quick"].config("rendered"), PRESETS["quick"].shared.repeat
    sweep = FirstRenders(evaluated=1.0)
    job = Job("path", "arena", 64, 0, "brute", REGISTRY["brute"].Options())
    _, samples, want = sweep.first_render(None, job)
    assert samples == [] and want == repeat                         # compiles: discarded
    _, samples, want = sweep.first_render(None, Job("path", "arena", 64, 1, "brute", job.opts))
    assert len(samples) == 1 and want == repeat                     # warm: counts
    sweep.serial += 1                                               # a new renderer compiles anew
    assert sweep.first_render(None, job)[1] == []
    heavy = FirstRenders(evaluated=p.heavy_eval_pp + 1)
    assert heavy.first_render(None, job)[2] == p.heavy_repeat
    study = Job("tile", "arena", 64, 0, "tiled", REGISTRY["tiled"].Options())
    assert sweep.first_render(None, study)[2] == p.study_repeat > repeat


def test_a_frame_read_back_before_is_not_rendered_again_but_timed_again():
    """An option study's default value is the path's frame 0: its row takes that read-back
    render's cells (figures, checks, model) under its own study, and all its timing samples
    are its own; the cutoff and caps studies, whose errors are their own, render anew."""
    p = PRESETS["quick"].config("rendered")
    sweep = FirstRenders(evaluated=1.0)
    opts = REGISTRY["tiled"].Options()
    path = Job("path", "arena", 64, 0, "tiled", opts)
    row, _, _ = sweep.first_render(None, path)
    again, samples, want = sweep.first_render(None, Job("tile", "arena", 64, 0, "tiled", opts))
    assert len(sweep.renders) == 1 and again == dict(row, study="tile")
    assert samples == [] and want == p.study_repeat
    other = opts.with_(tile=opts.tile * 2)                          # another configuration
    sweep.first_render(None, Job("tile", "arena", 64, 0, "tiled", other))
    sweep.first_render(None, Job("cutoff", "arena", 64, 0, "tiled", opts))
    assert len(sweep.renders) == 3
    sweep.serial += 1                                               # another renderer
    sweep.first_render(None, Job("tile", "arena", 64, 0, "tiled", opts))
    assert len(sweep.renders) == 4


def test_a_preset_may_model_the_first_frame_of_each_path_alone():
    """model_frames: the path rows past it get no wave replay (no section reads them on a
    software rasterizer), nor the rows of the unmodelled studies; every other row does."""
    from dataclasses import replace
    sweep = FirstRenders(evaluated=1.0)
    opts = REGISTRY["tiled"].Options()
    sweep.rendered = replace(sweep.rendered, model_frames=1, unmodelled=())
    assert sweep.modelled(Job("path", "arena", 64, 0, "tiled", opts))
    assert not sweep.modelled(Job("path", "arena", 64, 2, "tiled", opts))
    assert sweep.modelled(Job("cutoff", "arena", 64, 0, "tiled", opts, cutoff=256))
    sweep.rendered = replace(sweep.rendered, model_frames=0, unmodelled=("cutoff",))
    assert sweep.modelled(Job("path", "arena", 64, 2, "tiled", opts))
    assert not sweep.modelled(Job("cutoff", "arena", 64, 0, "tiled", opts, cutoff=256))
    assert sweep.modelled(Job("tile", "arena", 64, 0, "tiled", opts))
