"""The report's feature-variant study (app/report/variants.py): per scene and technique, the
time on / off and the figures the variants' stats give, from results rows as the sweep
writes them (the stats column: the frame's numeric meta stats)."""
import json

from app.bench.measure import figure_cells
from app.pipeline.renderer import Renderer
from app.report.notes import technique_notes
from app.report.variants import variant_notes
from app.techniques import REGISTRY
from scenes import load_scene


def row(study, res, on: bool, lighting_ms: float) -> dict:
    return {"study": study, "scene": "corridor", "lights": 64, "width": 64, "height": 36,
            "frame": 0, "technique": "tiled", "feature_variants": float(on), "samples": 3,
            "gpu_lighting_ms": lighting_ms, "gpu_lighting_min_ms": lighting_ms * 0.9,
            "gpu_lighting_max_ms": lighting_ms * 1.1, "stats": figure_cells(res)["stats"]}


def test_the_study_reads_the_variants_stats(gl):
    scene = load_scene("corridor", lights=64, seed=0)
    with Renderer(scene, (64, 36)) as r:
        on = r.render(REGISTRY["tiled"], opts={"feature_variants": True, "tile": 16})
        off = r.render(REGISTRY["tiled"], opts={"tile": 16})
    s = json.loads(figure_cells(on)["stats"])
    assert s["feature_variants"] >= 2 and s["variant_tiles_total"] == 4 * 3
    rows = [row("feature_variants", on, True, 2.0), row("feature_variants", off, False, 4.0),
            row("feature_variants@city", on, True, 3.0), row("feature_variants@city", off, False, 3.0)]
    title, text = variant_notes(rows)
    assert title and text.count("| tiled |") == 2
    line = text.splitlines()[text.splitlines().index(next(l for l in text.splitlines() if "| tiled |" in l))]
    assert "0.5x (lower beyond spread" in line
    assert f"{s['feature_variants']:.0f} of {s['variant_masks_seen']:.0f} masks" in line
    assert f"{100 * s['variant_specular_waste_off']:.1f}%" in line
    assert (title, text) in technique_notes(rows)
    assert variant_notes([r for r in rows if r["feature_variants"] == 1.0]) == ("", "")
