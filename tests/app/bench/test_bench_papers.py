"""The papers' settings (app.bench.validation), modelled only, and the report's sections that
read them: the modelled GPU cost per scene, the Pareto front under each GPU, the validation
beside the papers' figures and the measured-against-modelled section; and the gpu-check
preset scripts/gpu_check.sh runs."""
from __future__ import annotations

from dataclasses import replace
import math

import numpy as np
import pytest

from app import report
from app.report.validation import claims
from app.bench.plan import plan
from app.bench.presets import FULL, GPU_CHECK, QUICK
from app.bench.cpu_series import CpuStudy
from app.bench.sweep import Sweep
from app.bench.validation import (FIG7_BASE, FIG7_TECHNIQUES, FPTL_VISIBLE, PapersStudy,
                                  paper_jobs, scaled_lights)
from app.model import cost
from app.results import PAPER_PREFIX
from app.techniques import REGISTRY

SMALL = QUICK.changed(shared=dict(scenes=("arena", "corridor"), study_lights=256),
                      papers=dict(size=(96, 64), lights=(256, 512), frames=2, sample=2,
                                  path_sample=0, raster=True))
PAPERS = QUICK.config("papers")


def test_paper_jobs_are_the_papers_settings():
    jobs = paper_jobs(PAPERS)
    fig7 = [j for j in jobs if j.job.study == PAPER_PREFIX + "fig7"]
    assert len(fig7) == 2 * len(PAPERS.lights) * PAPERS.frames * len(FIG7_TECHNIQUES)
    for j in fig7:     # radii shrink so that a pixel's overdraw stays at the 8k value
        assert j.radius_scale == pytest.approx((FIG7_BASE / j.job.lights) ** (1 / 3))
    assert {j.sample for j in fig7} == {PAPERS.path_sample}
    assert {j.job.frame for j in fig7} == set(range(PAPERS.frames)) and PAPERS.frames >= 8
    assert FULL.config("papers").frames >= 16
    table = [j.job for j in jobs if j.job.study == PAPER_PREFIX + "zbin_table"]
    assert sorted(j.opts.zbin_variant for j in table) == [0, 1, 2, 3]    # raster's: --full
    assert all(j.lights == 256 for j in table)
    assert not [j for j in jobs if j.job.study == PAPER_PREFIX + "cluster_raster"]
    visible = [j for j in jobs if j.job.study == PAPER_PREFIX + "fptl_visible"]
    assert sorted((j.visible, j.job.opts.fptl_variant) for j in visible) == \
        [(k, v) for k in FPTL_VISIBLE for v in (0, 1)]
    full = paper_jobs(FULL.config("papers"))
    table = [j.job for j in full if j.job.study == PAPER_PREFIX + "zbin_table"]
    assert sorted((j.technique, j.opts.zbin_variant) for j in table) == \
        [(t, v) for t in ("raster", "zbin") for v in range(4)]
    cluster = [j.job.opts for j in full if j.job.study == PAPER_PREFIX + "cluster_raster"]
    assert sorted(o.raster_variant for o in cluster) == [0, 1, 2, 3]
    assert {(o.cluster, o.cluster_tile, o.cluster_slices) for o in cluster} == {(1, 32, 32)}
    assert 1920 // 32 == 60                        # the slides' 60 columns
    swept = [j.job.opts for j in full if j.job.study == PAPER_PREFIX + "cluster_tile"]
    assert sorted(o.cluster_tile for o in swept) == [8, 16, 64]     # 32: the table's row
    scenes = [j.job for j in jobs if j.job.study == PAPER_PREFIX + "scenes"]
    assert {j.technique for j in scenes} == {t for t, x in REGISTRY.items() if x.role != "floor"}
    assert not paper_jobs(replace(PAPERS, size=None))


def test_scaled_lights_scale_every_size():
    from scenes.model import make_lights
    L = make_lights(3)
    L["radius"], L["length"], L["extent"] = 2.0, 4.0, 1.0
    s = scaled_lights(L, 0.5)
    assert (s["radius"] == 1.0).all() and (s["length"] == 2.0).all() and (s["extent"] == 0.5).all()
    assert (L["radius"] == 2.0).all() and scaled_lights(L, 1.0) is L


def test_gpu_check_preset_plans_every_technique_on_two_scenes():
    jobs = plan(GPU_CHECK.config("rendered"), lambda scene, counts: tuple(counts))
    assert {j.study for j in jobs} == {"path"}
    assert {j.scene for j in jobs} == {"arena", "city"}
    assert {j.lights for j in jobs} == {8192, 65536}
    assert {j.technique for j in jobs} == set(REGISTRY)
    assert len(jobs) == len(REGISTRY) * 2 * 2 * GPU_CHECK.shared.frames
    assert GPU_CHECK.shared.size == (1920, 1080) and not paper_jobs(GPU_CHECK.config("papers"))
    assert not CpuStudy(GPU_CHECK.config("cpu")).jobs(Sweep(GPU_CHECK))


@pytest.fixture(scope="module")
def paper_rows(gl):
    return PapersStudy(SMALL.config("papers")).run(None, Sweep(SMALL))


def test_paper_rows_are_modelled_not_shaded(paper_rows):
    assert {r["study"] for r in paper_rows} == {PAPER_PREFIX + k for k in (
        "fig7", "zbin_table", "cluster_raster", "cluster_tile", "fptl", "fptl_visible", "scenes")}
    # the chapter's scene sizes: exactly 40, 80, 120 visible lights, a prefix of the scene's
    seen = sorted((r["visible"], r["fptl_variant"]) for r in paper_rows
                  if r["study"] == PAPER_PREFIX + "fptl_visible")
    assert seen == [(k, v) for k in FPTL_VISIBLE for v in (0, 1)]
    assert all(r["lights"] < 1024 for r in paper_rows if r["study"] == PAPER_PREFIX + "fptl_visible")
    for r in paper_rows:
        where = f"{r['study']} {r['scene']} {r['technique']}"
        assert r["width"] == 96 and r["height"] == 64, where
        assert r["model_version"] == cost.MODEL_VERSION, where
        for g in cost.GPUS:
            assert r[f"model_{g.key}_shade_ms"] > 0, where
            assert r[f"model_{g.key}_lighting_ms"] >= r[f"model_{g.key}_shade_ms"], where
        assert r["evaluated_pp"] > 0 and r["evaluated_pp"] >= r["exact_pp"], where  # the replay's
        assert "mismatch_count" not in r, where            # not checked here: no brute frame
        assert 0 < r["w32_simd"] <= 1 and 0 < r["w64_simd"] <= 1, where


def test_report_sections_from_paper_rows(paper_rows, tmp_path):
    info = {"software": True, "gl_renderer": "llvmpipe"}
    report.write_report(tmp_path, paper_rows, {}, info)
    md = (tmp_path / "report.md").read_text()
    for title in ("Modelled GPU cost at 1920x1080", "the Pareto front under each GPU",
                  "Validation: the cost model beside the papers' measurements",
                  "Which number to believe"):
        assert title in md, title
    assert md.count("**agrees**") + md.count("**close**") + md.count("**disagrees**") >= 20
    assert "-bound)" in md and "lowest geometric mean" in md and " by the rule); bound: " in md
    assert "The verdict rule" in md and "Where the model departs from the papers' GPUs" in md
    assert "Drobot's optimization table" in md and "| scalarized tile + zbin | 80% |" in md
    assert "| variant | slides | zbin: gtx980 |" in md and "| raster: ps4 |" in md
    assert "Drobot's hangar" in md and "re-counts the table's own" in md
    assert "Drobot's cluster-rasterizer table" in md
    assert "| variant | slides | atomics | of atomic | modelled PS4 culling | of atomic |" in md
    assert "| atomic + compaction + 4xMSAA | 0.32 ms (35%) |" in md
    assert "Mikkelsen's interior" in md and "| serial ms | hidden ms |" in md
    assert "The cluster rasterizer's clusters swept" in md and "The waste " in md
    for k in FPTL_VISIBLE:
        assert f"| {k} visible | fine |" in md and f"- Mikkelsen, {k} visible: fine pruning cheaper with the build hidden" in md
    assert "frame along the path" not in md and "along 2 frames spread over" in md
    for claim in ("fig7/", "zbin_table/zbin/", "zbin_table/raster/", "hangar/", "cluster_raster/",
                  "fptl/"):
        assert any(c.id.startswith(claim) for c in claims(paper_rows)), claim
    assert "No real GPU in this run" in md
    for png in ("gpu_scenes.png", "gpu_pareto.png", "validation_fig7.png"):
        assert (tmp_path / png).stat().st_size > 10_000, png


def test_measured_against_modelled_on_a_named_gpu(paper_rows, tmp_path):
    """Path rows measured on a GPU the model names: twice the modelled time reads 2.00x, and
    a measured order the model shares counts as agreeing."""
    rows = []
    for r in paper_rows:
        if r["study"] == PAPER_PREFIX + "scenes":
            m = dict(r, study="path", frame=0)
            m["gpu_lighting_ms"] = 2.0 * r["model_h200_lighting_ms"]
            rows.append(m)
    info = {"software": False, "gl_renderer": "NVIDIA H200/PCIe/SSE2"}
    from app.report.common import Colors, Roles
    from app.report.gpu import fig_measured
    png, text, table = fig_measured(rows, tmp_path, Colors(list(REGISTRY), Roles.from_registry()), info)
    assert png and (tmp_path / png).exists()
    assert "2.00x" in table and "0.50x" not in table
    frames = len({(r["scene"], r["lights"]) for r in rows})
    assert f"In {frames} of {frames} frames" in text[1]
    assert cost.match(info["gl_renderer"]).key == "h200" and cost.match("llvmpipe") is None


def test_every_modelled_time_is_derived_again_from_its_row(paper_rows, tmp_path):
    """A row's waves column (its figures and the counts that priced them) gives its modelled
    times again, and the report's model section prints the counts per variant."""
    from app.report import model as section
    for r in paper_rows:
        again = section.remodel(r)
        for g in cost.GPUS:
            for part in ("cull", "shade"):
                assert again[g.key][part] == pytest.approx(r[f"model_{g.key}_{part}_ms"], rel=1e-9), \
                    (r["study"], r["technique"], g.key, part)
    text, tables = section.model_section(paper_rows)
    assert f"Model v{cost.MODEL_VERSION}" in text[0]
    for name in cost.ASSUMED:
        assert any(f"`{name}`" in t for t in text), name
    for v in range(1, 4):                          # zbin's variants each their own counts
        assert f"| zbin | zbin_variant={v} |" in tables or (v == 3 and "| zbin | defaults |" in tables)
    assert "light_aabb (fptl_aabb.comp): aabb" in tables
