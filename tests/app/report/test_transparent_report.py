"""The report's transparent section (app.report.transparent): a cost over the opaque-only
frame is a finding only beyond the measured spread, a layer that differs from brute's is
named, and how each technique serves the layers is listed."""
import json

from app.report.transparent import exact_cell, frame_ratio, transparent_section


def row(technique="tiled", serves="rebuilt per layer", layered=(3.0, 2.9, 3.1),
        opaque=(2.0, 1.9, 2.1), per_layer=(0, 0), **kw):
    r = dict(scene="city-glass", lights=4096, width=128, height=72, layers=len(per_layer),
             max_layers=4, opaque_pixels=9000, samples=3, technique=technique, role="technique",
             serves=serves, rebuilt="its tiles' light lists" if serves != "looked up" else float("nan"),
             per_layer=json.dumps([{"layer": k, "fragments": 100, "evaluated_pf": 3.0,
                                    "exact_pf": 1.0, "mismatch": m} for k, m in enumerate(per_layer)]),
             mismatch_count=0, mismatch_hash=0, layer_mismatch_count=sum(per_layer),
             layer_mismatch_hash=0, opaque_differs=0, layer_bytes=1024,
             evaluated_pp=4.0, exact_pp=1.0, waste=4.0, evaluated_pf=3.0, exact_pf=1.0,
             waste_layers=3.0)
    for base, (med, lo, hi) in (("frame_cost", layered), ("opaque_frame_cost", opaque),
                                ("cpu_total", (1.0, 0.9, 1.1)), ("extra_cpu", (0.0, -0.1, 0.1)),
                                ("opaque_gpu_lighting", opaque), ("layers_gpu", (1.0, 0.9, 1.2))):
        r.update({f"{base}_ms": med, f"{base}_min_ms": lo, f"{base}_max_ms": hi})
    r.update(kw)
    return r


def test_a_frame_ratio_beyond_the_spread_is_a_finding_inside_it_is_not():
    assert frame_ratio(row()) == "1.50 [1.38-1.63] higher"
    assert frame_ratio(row(layered=(2.1, 1.5, 2.6))).endswith("within spread")
    assert frame_ratio(row(samples=1)).endswith("within spread")       # one sample: no spread


def test_a_layer_that_differs_from_brute_is_named():
    assert exact_cell(row()) == "yes"
    assert exact_cell(row(per_layer=(0, 7))) == "no (layer 1 7 px)"
    assert exact_cell(row(mismatch_hash=2)) == "no (opaque 2 px)"
    _, text, table = transparent_section([row(per_layer=(0, 7)), row("clustered", "looked up")])
    assert "no (layer 1 7 px)" in table and any("NOT exact: tiled" in t for t in text)


def test_how_each_serves_the_layers_and_the_cheapest_layers():
    rows = [row(), row("clustered", "looked up", layers_gpu_ms=0.5, layers_gpu_min_ms=0.45,
                       layers_gpu_max_ms=0.55, waste_layers=2.0)]
    png, text, table = transparent_section(rows)
    assert png is None and table.count("\n| ") == 3           # header rule + a row each
    assert any("rebuilt per layer: tiled (its tiles' light lists)" in t for t in text)
    assert any("looked up: clustered." in t for t in text)
    assert any("extra GPU time among the culling techniques is lowest at clustered" in t for t in text)
    assert any("from 0.50x (clustered) to 0.75x (tiled)" in t for t in text)
    assert "2 of at most 4 layers used (100, 100 fragments" in table


def test_write_report_holds_the_section_after_the_stereo_one(tmp_path):
    from app.report import write_report
    from app.report.transparent import CSV, PNG
    from app.results import write_csv
    rows = [row(), row("clustered", "looked up")]
    write_csv(rows, tmp_path / CSV, list(rows[0]))
    write_report(tmp_path, [], {}, {})
    md = (tmp_path / "report.md").read_text()
    assert "## Transparent layers" in md and f"({PNG})" in md and (tmp_path / PNG).exists()
    assert "| tiled | rebuilt per layer |" in md and "| clustered | looked up |" in md
