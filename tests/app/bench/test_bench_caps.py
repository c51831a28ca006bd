"""The cap-policy bench series (app.bench.caps): its jobs (every list technique at none and at
each view policy that drops lights, the others skipped and said so; the per-tile policies on
fptl alone), placed after the caps scene's last job, and its rows measured by the sweep (a
capped configuration loses pixels and image; none has the exact figures; both exact on the
lights they keep)."""
from dataclasses import replace
import io
import json

import pytest

from app.bench.caps import CAPS, cap_techniques, caps_jobs, dropped_lights, with_caps_jobs
from app.bench.plan import plan
from app.bench.presets import QUICK
from app.bench.sweep import Sweep
from cpu_prep import caps

TINY = QUICK.changed(shared=dict(size=(64, 36), frames=1, scenes=("arena",), lights=(256,),
                                 option_studies=False),
                     rendered=dict(study_repeat=2, cutoffs=(256,), cutoff_scenes=("arena",),
                                   cutoff_lights=256, caps_scenes=("arena",), caps_lights=256))
RENDERED_TINY = TINY.config("rendered")
RENDERED = ("tiled", "clustered")        # a GPU-built list and a CPU-binned one


def _policy(job) -> str:
    return caps.NAMES[job.opts.cap_policy]


@pytest.fixture(scope="module")
def series(gl):
    from app.pipeline.renderer import Renderer
    log = io.StringIO()
    sw = Sweep(TINY, log)
    sc = sw.scene("arena", 256)
    jobs = caps_jobs(RENDERED_TINY, "arena", 256, sc, log)
    with Renderer(sc, TINY.shared.size) as r:
        sw.measure_group(r, [j for j in jobs if j.technique in RENDERED or caps.per_tile(_policy(j))],
                         1, len(jobs))
    return jobs, sw.rows, log.getvalue(), dropped_lights(sc, TINY.shared.size, 0, TINY.shared.frames)


def test_jobs_every_list_technique_at_the_policies_that_drop(series):
    jobs, _, log, dropped = series
    assert set(cap_techniques()) == {j.technique for j in jobs} and len(cap_techniques()) >= 2
    biting = {p for p in caps.NAMES if dropped[p]}
    # ~190 of 256 lights visible: the 32- and 16-light caps bite, the 256- and 512-light ones not
    assert {"urp-32", "urp-16"} <= biting and not biting & {"urp-256", "filament-256", "hdrp-view"}
    assert dropped[caps.NONE] == 0
    assert {_policy(j) for j in jobs} == biting | {caps.NONE} | set(caps.TILE_NAMES)
    assert {j.technique for j in jobs if caps.per_tile(_policy(j))} == {"fptl"}
    assert all(j.study == CAPS and j.cutoff == 0 and j.frame == 0 for j in jobs)
    skipped = [p for p in caps.NAMES if p != caps.NONE and p not in biting and not caps.per_tile(p)]
    assert f"{', '.join(skipped)} drop nothing" in log


def test_caps_jobs_follow_the_scene_s_last_job():
    from scenes import load_scene
    p = TINY.changed(shared=dict(scenes=("arena", "city"))).config("rendered")
    counts = lambda scene, c: tuple(c)
    base = plan(p, counts)
    jobs = with_caps_jobs(base, p, counts, lambda n, k: load_scene(n, lights=k, seed=0))
    k = max(i for i, j in enumerate(base) if j.scene == "arena") + 1
    added = [j for j in jobs if j.study == CAPS]
    assert jobs[:k] == base[:k] and jobs[k:k + len(added)] == added and jobs[k + len(added):] == base[k:]
    assert {j.scene for j in added} == {"arena"}
    assert with_caps_jobs(base, replace(p, caps_scenes=()), counts, None) == base


def test_rows_lose_pixels_and_image_where_capped(series):
    _, rows, _, dropped = series
    assert {r["technique"] for r in rows} == set(RENDERED) | {"fptl"}
    stats = lambda r: json.loads(r["stats"])
    by = {(r["technique"], caps.NAMES[r["cap_policy"]]): r for r in rows}
    for r in rows:
        where = (r["technique"], caps.NAMES[r["cap_policy"]])
        assert r["study"] == CAPS and r["error_ref"] == "unbounded", where
        # exact on the lights it kept: brute without the dropped ones
        assert r["mismatch_count"] == 0 and r["mismatch_hash"] == 0, where
        assert r["samples"] == RENDERED_TINY.study_repeat and r["frame_cost_ms"] > 0, where
    # HDRP FPTL per tile: the arena's small lights leave its tiles under 24 here, so its rows
    # drop nothing; tests/app/techniques/test_fptl_tile_caps.py holds the counts where it bites
    for t in RENDERED:
        none = by[(t, caps.NONE)]
        assert stats(none)["lost_pixels"] == 0 and stats(none)["lost_contributions"] == 0
        assert "capped_lights" not in stats(none)
        assert none["image_error"] > 0          # the scene's radii cut the unbounded tails
        prev = none
        for pol in ("urp-32", "urp-16"):
            r = by[(t, pol)]
            s = stats(r)
            assert s["capped_lights"] == dropped[pol] == none["visible"] - caps.POLICIES[pol].budgets[0][1]
            assert s["lost_pixels"] > 0 and s["lost_contributions"] > 0
            assert r["image_error"] > prev["image_error"] and r["image_flip"] > prev["image_flip"]
            assert r["radiance_ratio"] < prev["radiance_ratio"]
            assert r["exact_pp"] < none["exact_pp"]
            prev = r
    # none has the exact figures: every technique the same image and light sets
    a, b = (by[(t, caps.NONE)] for t in RENDERED)
    assert a["image_error"] == pytest.approx(b["image_error"], rel=1e-4)
    assert a["exact_pp"] == b["exact_pp"]
    for pol in ("urp-32", "urp-16"):
        a, b = (by[(t, pol)] for t in RENDERED)
        assert json.loads(a["stats"])["lost_pixels"] == json.loads(b["stats"])["lost_pixels"]
        assert a["image_error"] == pytest.approx(b["image_error"], rel=1e-4)


def test_presets_wire_the_series():
    """quick and full run it in the arena at the cutoff study's light count, gpu-check not;
    --scenes and --lights narrow it as they narrow the cutoff study."""
    from argparse import Namespace
    from app.bench.presets import FULL, GPU_CHECK, preset_from_args
    for p in (QUICK.config("rendered"), FULL.config("rendered")):
        assert p.caps_scenes == ("arena",) and p.caps_lights == p.cutoff_lights
    assert GPU_CHECK.config("rendered").caps_scenes == ()
    blank = dict(full=False, gpu_check=False, size=None, scenes=None, lights=None, frames=None,
                 repeat=None, cpu_lights=None, cpu_size=None, threads=None)
    p = preset_from_args(Namespace(**dict(blank, scenes="city,arena", lights="512,1024")))
    p = p.config("rendered")
    assert p.caps_scenes == ("city",) and p.caps_lights == 512
    gpu_check = preset_from_args(Namespace(**dict(blank, gpu_check=True, scenes="city")))
    assert gpu_check.config("rendered").caps_scenes == ()
