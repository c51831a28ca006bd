"""The sampling section (app.report.sampling) on synthetic rows: the crossover against the
mildest cap that loses light, with a crossover and without one, the figure and the section."""
import json
import math

import pytest

from app.report import sampling
from app.report.common import Roles
from app.results import read_csv, write_csv

LO, HI = [1, 2, 4], [1, 3, 7]
PIXELS, GEOMETRY = [100, 100, 100], 400


def _row(config, kind, technique, err, s="", seed_bins=None, policy="none", cost=5.0):
    errs = seed_bins or [[err * 2.0] * 3]
    whole = [math.sqrt(sum(p * e * e for p, e in zip(PIXELS, b)) / GEOMETRY) for b in errs]
    return {"study": "sampling", "scene": "arena", "lights": 1024, "width": 96, "height": 64,
            "config": config, "kind": kind, "technique": technique, "role": "technique",
            "policy": policy, "samples_per_pixel": s, "seeds": len(errs),
            "image_error": sorted(whole)[len(whole) // 2] if kind == "sampler" else err,
            "image_error_min": min(whole) if kind == "sampler" else err,
            "image_error_max": max(whole) if kind == "sampler" else err,
            "image_flip": 0.0, "image_flip_min": 0.0, "image_flip_max": 0.0,
            "seed_errors": json.dumps(whole), "evaluated_pp": float(s or 10.0),
            "evaluated_lit_pp": float(s or 10.0), "shadow_pp": 3.0, "shadow_bound": int(kind == "sampler"),
            "exact_pp": 3.0, "mismatch_count": 0, "frame_cost_ms": cost, "frame_cost_min_ms": cost * 0.9,
            "frame_cost_max_ms": cost * 1.1, "timing_samples": 3, "cpu_total_ms": 1.0, "gpu_lighting_ms": cost - 1.0,
            "bins": json.dumps({"lo": LO, "hi": HI, "pixels": PIXELS, "geometry": GEOMETRY,
                                "err": errs})}


def _sampler(s, per_bin):
    """A sampler row at S whose seeds' bin errors are per_bin / sqrt(S) (+-10% over 3 seeds)."""
    seeds = [[e * f / math.sqrt(s) for e in per_bin] for f in (0.9, 1.0, 1.1)]
    return _row(f"sample-list S={s}", "sampler", "sample-list", 0.0, s=s, seed_bins=seeds,
                cost=2.0 + s)


def _rows(cap_error):
    rows = [_row("brute", "exact", "brute", 0.0, cost=40.0),
            _row("tiled", "exact", "tiled", 0.0, cost=20.0),
            _row("urp-16 (tiled)", "cap", "tiled", 0.9, policy="urp-16", cost=8.0),
            _row("urp-32 (tiled)", "cap", "tiled", cap_error, policy="urp-32", cost=9.0),
            _row("hdrp-fptl-24 (fptl)", "cap", "fptl", 0.0, policy="hdrp-fptl-24")]
    # the error grows with the lights affecting a pixel: bins 1, 2-3, 4-7
    return rows + [_sampler(s, [0.2, 0.6, 1.6]) for s in (1, 4, 16, 64)]


def test_the_named_cap_is_the_mildest_that_loses_light():
    assert sampling.named_cap(_rows(0.3), "arena")["config"] == "urp-32 (tiled)"
    assert sampling.named_cap(_rows(0.0), "arena")["config"] == "urp-16 (tiled)"
    rows = [r for r in _rows(0.3) if r["kind"] != "cap" or r["image_error"] == 0]
    assert sampling.named_cap(rows, "arena") is None


def test_a_crossover_in_light_count_and_in_s():
    c, = sampling.crossover(_rows(0.3))
    assert c["cap"] == "urp-32 (tiled)" and c["cap_error"] == 0.3
    reach = {x["s"]: x for x in c["reach"]}
    # S=1: the first bin alone gives sqrt(100/400) * 0.2 * f = 0.09-0.11 <= 0.3, bins 1-2
    # 0.32 * f: over 0.3 for the median seed and the upper one, within for the lower one
    assert (reach[1]["med"], reach[1]["lo"], reach[1]["hi"]) == (1, 1, 3)
    assert not reach[1]["whole"]
    # S=4: /2: bins 1-3 (0.16 f) within, the whole frame (0.86 / 2 f = 0.39-0.47) beyond
    assert (reach[4]["med"], reach[4]["lo"], reach[4]["hi"]) == (3, 3, 3)
    assert not reach[4]["whole"]
    # S=16: /4: the whole frame (0.19-0.24) within for every seed
    assert reach[16]["whole"] and reach[16]["lo"] == 7 and reach[64]["whole"]
    # the frame error 0.86 / sqrt(S) meets 0.3 at S = (0.86 / 0.3)^2 = 8.2, interpolated
    # between S = 4 and 16 on the log-log line it follows exactly
    med, lo, hi = c["s_star"]
    whole = math.sqrt((0.2 ** 2 + 0.6 ** 2 + 1.6 ** 2) * 100 / 400)
    assert med == pytest.approx((whole / 0.3) ** 2, rel=1e-9)
    assert lo < med < hi
    assert c["closest"]["s"] in (4, 16) and not c["closest"]["within"]
    (names, err, s9), = c["others"]                     # urp-16's 0.9: below S=1
    assert names == ["urp-16"] and s9 == 0.0
    text, = sampling.crossover_sentences(_rows(0.3))
    # the nearest S (16: 0.215 against 0.3) costs 18 ms [16.2, 19.8], the cap 9 [8.1, 9.9]
    assert "against the cap's 9 ms [8.1 ms, 9.9 ms]: higher beyond spread" in text
    assert "urp-32 (tiled)" in text and "S=4: 3 [3, 3];" in text and "S=16: 7 [7, 7] (every bin)" in text and f"S* = {med:.3g}" in text


def test_no_crossover_within_the_measured_s():
    rows = [r for r in _rows(0.01) if r["policy"] != "urp-16"]
    c, = sampling.crossover(rows)
    assert c["cap"] == "urp-32 (tiled)"                  # reached by no S: the mildest
    assert all(x["hi"] == 0 for x in c["reach"])         # not even the first bin, any seed
    assert all(math.isinf(v) for v in c["s_star"])
    assert not c["closest"]["within"] and c["closest"]["s"] == 64
    text, = sampling.crossover_sentences(rows)
    assert "beyond S=64" in text and "S=1: 0 [0, 0]" in text and "above the cap's" in text
    no_cap = [r for r in _rows(0.3) if r["kind"] != "cap" or r["image_error"] == 0]
    text, = sampling.crossover_sentences(no_cap)
    assert "no cap policy loses light" in text


def test_a_milder_cap_no_s_reaches_is_passed_over_and_still_reported():
    c, = sampling.crossover(_rows(0.01))
    assert c["cap"] == "urp-16 (tiled)" and c["cap_error"] == 0.9
    (names, err, s_star), = c["others"]
    assert names == ["urp-32"] and err == 0.01 and math.isinf(s_star)
    # 0.86 / sqrt(S) = 0.9 below S = 1: the whole frame within at every S, every seed
    assert c["s_star"][0] == 0.0 and all(x["whole"] for x in c["reach"][1:])
    text, = sampling.crossover_sentences(_rows(0.01))
    assert "S* = below S=1" in text and "urp-32 (0.01): beyond S=64" in text


def test_meet_interpolates_in_log_log():
    assert sampling.meet([1, 4], [1.0, 0.5], 0.5 ** 0.5) == pytest.approx(2.0)
    assert sampling.meet([1, 4], [0.1, 0.05], 0.5) == 0.0
    assert math.isinf(sampling.meet([1, 4], [1.0, 0.9], 0.5))


def test_the_figure_and_section_render(tmp_path):
    rows = _rows(0.3)
    write_csv(rows, tmp_path / sampling.CSV, list(rows[0]))
    back = read_csv(tmp_path / sampling.CSV)          # as the report reads the study's file
    png, text, extra = sampling.sampling_section(back, tmp_path, Roles.from_registry())
    assert png == "sampling.png" and (tmp_path / png).stat().st_size > 10_000
    assert any("urp-32 (tiled)" in t for t in text)
    assert any("Visibility is not simulated" in t for t in text)
    assert "| arena | sample-list S=16 | 16 |" in extra and "<= 3" in extra
    assert "not a finding" in extra and f"c = {sampling.VISIBILITY_C:g}" in extra
    assert sampling.sampling_section([], tmp_path, Roles.from_registry()) == (None, [], "")


def test_write_report_holds_the_section(tmp_path):
    from app.report import write_report
    rows = _rows(0.3)
    write_csv(rows, tmp_path / sampling.CSV, list(rows[0]))
    write_report(tmp_path, [], {}, {})
    md = (tmp_path / "report.md").read_text()
    assert "## Sampling against culling" in md and "(sampling.png)" in md


def test_a_cost_inside_the_measured_spread_is_no_finding():
    from app.report.spread import Spread
    a, b = Spread(10.0, 9.0, 11.0, 3), Spread(10.5, 10.0, 12.0, 3)
    assert sampling.cost_phrase(a, b) == "within spread"
    assert sampling.cost_phrase(Spread(5.0, 4.0, 6.0, 3), b) == "lower beyond spread"
    assert sampling.cost_phrase(Spread(5.0, 4.0, 6.0, 1), b) == "within spread"   # one sample


def test_the_crossover_by_flip_where_the_cap_has_one():
    rows = _rows(0.3)
    for r in rows:
        if r["policy"] == "urp-32":
            r["image_flip"] = 0.1
        if r["kind"] == "sampler":
            f = 0.2 / math.sqrt(r["samples_per_pixel"])
            r.update(image_flip=f, image_flip_min=0.9 * f, image_flip_max=1.1 * f)
    c, = sampling.crossover(rows)
    med, lo, hi = c["flip_star"]
    assert med == pytest.approx(4.0) and lo < med < hi      # 0.2 / sqrt(S) = 0.1 at S = 4
    text, = sampling.crossover_sentences(rows)
    assert "by FLIP (the cap's 0.1) S* = 4 [" in text
    assert sampling.crossover(_rows(0.3))[0]["flip_star"] is None      # the cap's FLIP 0
