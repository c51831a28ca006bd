"""The report's stereo section (app.report.stereo): a ratio is a finding only beyond the
measured spread."""
from app.report.stereo import stereo_section


def row(way, cpu, lo, hi, share="structure", entries=100):
    return dict(scene="arena", lights=2048, width=160, height=90, separation=0.064, samples=3,
                technique="clustered", way=way, share=share if way == "union" else "",
                entries=entries, bytes=1000, cpu_total_ms=cpu, cpu_total_min_ms=lo,
                cpu_total_max_ms=hi, gpu_lighting_ms=2.0, gpu_lighting_min_ms=1.9,
                gpu_lighting_max_ms=2.1, mismatch_count=0, mismatch_hash=0)


def ratio_line(rows):
    return next(l for l in stereo_section(rows)[2].splitlines() if "union / per-view" in l)


def test_a_ratio_beyond_the_spread_is_a_finding_inside_it_is_not():
    apart = ratio_line([row("per-view", 2.0, 1.9, 2.1, entries=200), row("union", 1.0, 0.9, 1.1)])
    assert "| 0.50 |" in apart and "0.50 [0.43-0.58] lower" in apart
    close = ratio_line([row("per-view", 2.0, 1.5, 2.5), row("union", 1.9, 1.4, 2.4)])
    assert "within spread" in close and "lower" not in close
    text = stereo_section([row("per-view", 2.0, 1.9, 2.1, entries=200), row("union", 1.0, 0.9, 1.1)])[1]
    assert any("clustered shares its structure" in t for t in text)


def test_an_inexact_eye_shows():
    bad = row("union", 1.0, 0.9, 1.1)
    bad["mismatch_count"] = 3
    assert "no (3 px)" in stereo_section([row("per-view", 2.0, 1.9, 2.1), bad])[2]
