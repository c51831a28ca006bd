"""The fog study (app.bench.fog) on a tiny frame: every technique that serves froxels held to
brute's sets, its cost split from the frame's, the refusing ones listed with their reason,
the banding case on the study's grid and the matched one, its files read back by the
report's section; the presets carry it."""
from types import SimpleNamespace

import numpy as np
import pytest

from app.bench import presets
from app.bench.fog import (BANDING, COLUMNS, CSV, FOG_CPU_STEPS, FogConfig, banding_technique,
                           fog_series, grid_dims)
from app.pipeline.fog import source_of
from app.report.fog import PNG, fog_section
from app.results import read_csv
from app.techniques import REGISTRY


@pytest.fixture(scope="module")
def study(gl, tmp_path_factory):
    out = tmp_path_factory.mktemp("fog")
    rows = fog_series(FogConfig(("hangar-fog",), 300, (64, 36), (16, 9, 8), repeat=2), out)
    return out, rows


def test_serving_techniques_exact_and_the_refusing_ones_listed(study):
    out, rows = study
    assert (out / CSV).read_text().splitlines()[0].split(",") == COLUMNS
    served = [r for r in rows if r["kind"] == "froxels"]
    refused = [r for r in rows if r["kind"] == "refused"]
    assert [r["technique"] for r in served] == [t.name for t in REGISTRY.values() if source_of(t)]
    assert [r["technique"] for r in refused] == [t.name for t in REGISTRY.values() if not source_of(t)]
    assert all(r["refusal"].startswith(r["technique"]) for r in refused)
    lights = {r["lights_pf"] for r in served}
    assert len(lights) == 1 and lights.pop() > 0          # every technique: the same exact sets
    for r in served:
        assert r["froxels"] == "16x9x8" and r["froxel_count_total"] == 16 * 9 * 8
        assert r["froxel_mismatch"] == r["mismatch_count"] == r["mismatch_hash"] == 0
        assert r["unneeded_pf"] == pytest.approx(r["candidates_pf"] - r["lights_pf"], abs=1e-3)
        assert r["samples"] == 2 and r["sets_cpu_min_ms"] <= r["sets_cpu_ms"] <= r["sets_cpu_max_ms"]
        assert 0 < r["sets_cpu_ms"] <= r["fog_cpu_ms"] and r["fog_gpu_ms"] > 0
        assert set(p.split("=")[0] for p in r["fog_passes"].split(";")) == \
            {"fog_light", "fog_march", "fog_composite"}
        cells = source_of(REGISTRY[r["technique"]]) != "all"
        assert (r["froxels_matched"] != "") == cells
        if cells:      # the cells narrow the candidates below every visible light's
            assert r["candidates_pf"] < served[0]["candidates_pf"] and r["unneeded_pf_matched"] >= 0


def test_the_fog_steps_are_split_from_the_frame(gl):
    from app.bench.fog import split
    from app.pipeline.renderer import Renderer
    from scenes import load_scene
    with Renderer(load_scene("hangar-fog", 100), (32, 18)) as r:
        meta = r.render(REGISTRY["clustered"], readback=False).meta
    assert set(FOG_CPU_STEPS) <= set(meta["cpu_ms"])
    fog, frame, sets = split(meta, ("fog_light", "fog_march", "fog_composite"))
    assert set(fog["cpu_ms"]) == set(FOG_CPU_STEPS) and sets == meta["cpu_ms"][FOG_CPU_STEPS[0]]
    assert not set(frame["cpu_ms"]) & set(FOG_CPU_STEPS) and "shade" in frame["gpu_ms"]
    assert set(fog["gpu_ms"]) == {"fog_light", "fog_march", "fog_composite"}


def test_the_banding_case_bands_on_the_study_grid_only(study):
    out, rows = study
    bands = {r["grid"]: r for r in rows if r["kind"] == "banding"}
    assert set(bands) == {"16x9x8", "matched"}
    assert all(r["technique"] == banding_technique().name for r in bands.values())
    assert bands["16x9x8"]["error"] > 0 and bands["16x9x8"]["pixels_off"] > 0
    assert bands["matched"]["error"] == 0 and bands["matched"]["pixels_off"] == 0
    with np.load(out / BANDING) as z:
        assert set(z.files) == {f"hangar-fog/{g}/{k}" for g in bands
                                for k in ("exact", "centre", "difference")}
        assert z["hangar-fog/matched/difference"].max() == 0
        assert z["hangar-fog/16x9x8/difference"].max() > 0


def test_the_report_section_tables_the_serving_techniques_and_draws_the_banding(study):
    out, _ = study
    png, text, table = fog_section(read_csv(out / CSV), out)
    assert png == PNG and (out / PNG).stat().st_size > 0
    for t in REGISTRY.values():
        assert sum(line.startswith(f"| {t.name} |") for line in table.splitlines()) == \
            (1 if source_of(t) else 0)
    assert "no (" not in table
    assert any("refuse the fog frame" in t for t in text)
    assert any("banding case" in t and "matched grid 0.00%" in t for t in text)
    assert fog_section([]) == (None, [], "")


def test_the_grid_fits_the_image_and_no_scene_writes_nothing(gl, tmp_path):
    from app.errors import UserError
    assert grid_dims(FogConfig(("hangar-fog",), 1, (32, 18), (40, 23, 16), 1)) == (32, 18, 16)
    with pytest.raises(UserError, match="no fog"):
        fog_series(FogConfig(("hangar",), 64, (32, 18), (8, 4, 4), repeat=1), tmp_path)
    for name in (CSV, BANDING):
        (tmp_path / name).write_text("stale")
    assert fog_series(FogConfig((), 64, (32, 18), (8, 4, 4), repeat=1), tmp_path) == []
    assert not (tmp_path / CSV).exists() and not (tmp_path / BANDING).exists()


def test_the_presets_carry_the_study_and_the_overrides_reach_it():
    quick = presets.QUICK.config("fog")
    w, h, d = quick.froxels
    assert quick.scenes == ("hangar-fog",) and w * h * d <= 160 * 90 * 64 // 16
    assert presets.GPU_CHECK.config("fog").scenes == ()
    args = SimpleNamespace(full=False, size=(32, 18), scenes=None, lights="128,256", frames=None,
                           repeat=2, cpu_lights=None, cpu_size=None, threads=None)
    got = presets.preset_from_args(args).config("fog")
    assert (got.size, got.scenes, got.lights, got.repeat) == ((32, 18), ("hangar-fog",), 128, 2)
