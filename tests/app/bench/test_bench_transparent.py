"""The transparent study (app.bench.transparent) on a tiny frame: every technique's frame with
its layers against its opaque-only frame, exact per layer, how each serves the layers as it
declares, its file read back by the report's section; the presets carry it."""
import json
from types import SimpleNamespace

import pytest

from app.bench import presets
from app.bench.transparent import (COLUMNS, CSV, LOOKED_UP, REBUILT, TransparentConfig,
                                   opaque_only, serves, techniques, transparent_series)
from app.report.transparent import PNG, transparent_section
from app.results import read_csv
from scenes import load_scene


@pytest.fixture(scope="module")
def study(gl, tmp_path_factory):
    out = tmp_path_factory.mktemp("transparent")
    rows = transparent_series(TransparentConfig(("city-glass",), 4096, (48, 27), repeat=2, layers=3), out)
    return out, rows


def test_every_technique_exact_per_layer_against_its_opaque_only_frame(study):
    out, rows = study
    assert (out / CSV).read_text().splitlines()[0].split(",") == COLUMNS
    assert [r["technique"] for r in rows] == [t.name for t in techniques()]
    for r in rows:
        assert 1 <= r["layers"] <= r["max_layers"] == 3 and r["fragments"] > 0
        assert r["mismatch_count"] == r["mismatch_hash"] == 0
        assert r["layer_mismatch_count"] == r["layer_mismatch_hash"] == 0
        assert r["opaque_differs"] == 0          # the opaque-only frame is the same opaque frame
        per = json.loads(r["per_layer"])
        assert len(per) == r["layers"] and sum(p["fragments"] for p in per) == r["fragments"]
        assert all(p["mismatch"] == 0 for p in per)
        assert r["samples"] == 2 and r["layers_gpu_min_ms"] <= r["layers_gpu_ms"] <= r["layers_gpu_max_ms"]
        assert r["layers_gpu_ms"] > 0 and r["peel_ms"] > 0 and r["composite_ms"] > 0
        assert r["gpu_lighting_ms"] >= r["layers_gpu_ms"]          # the layers are inside the frame
        assert r["exact_pf"] > 0 and r["evaluated_pf"] >= r["exact_pf"]
        assert r["layer_bytes_total"] == r["layer_bytes"] * r["layers"]
    by = {r["technique"]: r for r in rows}
    floor = next(r for r in rows if r["role"] == "floor")
    assert floor["waste"] == pytest.approx(1.0) and floor["waste_layers"] == pytest.approx(1.0)
    # the same exact lights a sample kind whatever the technique
    assert len({round(r["exact_pf"], 6) for r in rows}) == len({round(r["exact_pp"], 6) for r in rows}) == 1
    for t in techniques():
        how, what = serves(t)
        assert by[t.name]["serves"] == how and (what != "") == (how == REBUILT)
        if how == REBUILT:                 # its GPU passes make a structure over each layer
            assert by[t.name]["layer_bytes"] > 0
    assert {r["serves"] for r in rows} == {LOOKED_UP, REBUILT}


def test_the_opaque_only_scene_drops_the_transparent_meshes_alone():
    scene = load_scene("city-glass", 64)
    alone = opaque_only(scene)
    assert alone.transparent_meshes() == [] and scene.transparent_meshes()
    assert len(alone.meshes) == len(scene.meshes) - len(scene.transparent_meshes())
    assert alone.lights is scene.lights


def test_the_report_section_tables_every_technique_and_draws_its_figure(study):
    out, rows = study
    png, text, table = transparent_section(read_csv(out / CSV), out)
    assert png == PNG and (out / PNG).stat().st_size > 0
    for t in techniques():
        assert sum(line.startswith(f"| {t.name} |") for line in table.splitlines()) == 1
    assert "no (" not in table and any("equal brute's" in t for t in text)
    assert any(REBUILT in t for t in text) and any(LOOKED_UP in t for t in text)
    assert transparent_section([]) == (None, [], "")


def test_a_scene_without_transparent_surfaces_is_refused_and_no_scene_writes_nothing(gl, tmp_path):
    from app.errors import UserError
    with pytest.raises(UserError, match="no transparent surface"):
        transparent_series(TransparentConfig(("arena",), 64, (32, 18), repeat=1), tmp_path)
    (tmp_path / CSV).write_text("stale")
    assert transparent_series(TransparentConfig((), 64, (32, 18), repeat=1), tmp_path) == []
    assert not (tmp_path / CSV).exists()


def test_the_presets_carry_the_study_and_the_overrides_reach_it():
    quick = presets.QUICK.config("transparent")
    assert quick.scenes == ("city-glass",) and quick.size[0] * quick.size[1] <= 160 * 90
    assert presets.FULL.config("transparent").scenes and presets.GPU_CHECK.config("transparent").scenes == ()
    args = SimpleNamespace(full=False, size=(32, 18), scenes=None, lights="128,256", frames=None,
                           repeat=2, cpu_lights=None, cpu_size=None, threads=None)
    got = presets.preset_from_args(args).config("transparent")
    assert (got.size, got.scenes, got.lights, got.repeat) == ((32, 18), ("city-glass",), 128, 2)
