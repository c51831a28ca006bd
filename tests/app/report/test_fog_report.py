"""The report's fog section (app.report.fog): froxel sets that differ from brute's show, the
matched grid's figure stands beside the frame grid's, the refusing techniques are listed,
and the banding sentence gives each grid's pixels off and largest error."""
from app.report.fog import banding_line, exact_cell, fog_section


def served(technique="clustered", source="cells", matched="4x2x16", unneeded_m=23.8, **kw):
    r = dict(scene="hangar-fog", kind="froxels", lights=1024, width=160, height=90, samples=3,
             technique=technique, role="technique", source=source, froxels="40x23x16",
             froxel_count_total=14720, lights_pf=38.0, candidates_pf=123.0, unneeded_pf=85.0,
             froxels_matched=matched, unneeded_pf_matched=unneeded_m, froxel_mismatch=0,
             mismatch_count=0, mismatch_hash=0)
    for base, v in (("sets_cpu", 160.0), ("fog_cpu", 165.0), ("fog_gpu", 15.0), ("frame_cost", 40.0)):
        r.update({f"{base}_ms": v, f"{base}_min_ms": 0.9 * v, f"{base}_max_ms": 1.1 * v})
    r.update(kw)
    return r


def band(grid, error, off):
    return dict(scene="hangar-fog", kind="banding", technique="clustered", grid=grid,
                radius_scale=0.2, froxel_samples=8, error=error, pixels_off=off)


def refused(technique):
    return dict(scene="hangar-fog", kind="refused", technique=technique,
                refusal=f"{technique} does not serve froxels")


def test_froxel_sets_that_differ_from_brute_show():
    assert exact_cell(served()) == "yes"
    assert exact_cell(served(froxel_mismatch=5)) == "no (5 froxels)"
    assert exact_cell(served(mismatch_count=2, froxel_mismatch=1)) == "no (1 froxels, 2 px)"
    _, text, _ = fog_section([served(froxel_mismatch=5)])
    assert any("NOT exact: clustered" in t for t in text)


def test_the_table_the_matched_grid_and_the_refusing_techniques():
    rows = [served("brute", "all", float("nan"), float("nan"), candidates_pf=915.0, unneeded_pf=877.0),
            served(), refused("tiled"), refused("zbin")]
    png, text, table = fog_section(rows)
    assert png is None
    brute = next(l for l in table.splitlines() if l.startswith("| brute |"))
    assert "| 915 | 877 |  |  | yes |" in brute          # no matched grid for every light
    assert "| 4x2x16 | 23.8 | yes |" in next(l for l in table.splitlines() if l.startswith("| clustered |"))
    assert any("85 on the 40x23x16 grid, 23.8 on its matched grid (4x2x16)" in t for t in text)
    assert any("refuse the fog frame: tiled, zbin (" in t for t in text)
    other = dict(refused("hybrid"), refusal="hybrid: --build gpu with a fog scene")
    lines = [t for t in fog_section(rows + [other])[1] if "refuse the fog frame" in t]
    assert len(lines) == 2 and lines[1].endswith('hybrid ("hybrid: --build gpu with a fog scene").')
    assert "| tiled |" not in table


def test_the_banding_sentence_gives_both_grids():
    line = banding_line("hangar-fog", [band("40x23x16", 0.0032, 0.1187), band("matched", 0.0, 0.0)])
    assert "on the 40x23x16 grid 11.87% of the pixels" in line and "0.32% of the brightest" in line
    assert "on the matched grid 0.00% of the pixels" in line and "radii x0.2" in line
    assert banding_line("hangar-fog", []) == ""


def test_write_report_holds_the_section_and_the_banding_images(tmp_path):
    import numpy as np
    from app.report import write_report
    from app.report.fog import BANDING, CSV, KINDS, PNG
    from app.results import write_csv
    rows = [served(), band("40x23x16", 0.0032, 0.1187), band("matched", 0.0, 0.0), refused("tiled")]
    cols = list(dict.fromkeys(k for r in rows for k in r))
    write_csv(rows, tmp_path / CSV, cols)
    image = np.zeros((9, 16, 3), np.uint8)
    np.savez(tmp_path / BANDING, **{f"hangar-fog/{g}/{k}": image for g in ("40x23x16", "matched")
                                    for k in KINDS})
    write_report(tmp_path, [], {}, {})
    md = (tmp_path / "report.md").read_text()
    assert "## Fog" in md and f"({PNG})" in md and (tmp_path / PNG).exists()
    assert "| clustered | cells |" in md and "banding case" in md
