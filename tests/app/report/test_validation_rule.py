"""The validation section's one verdict rule (app/report/validation.py) at its edges, and the
claims re-judged through another accessor of modelled milliseconds."""
import importlib

import pytest

from app.report import gpu_record
from app.report.validation import AGREES, CLOSE, DISAGREES, NEAR, claims, gap, modelled_ms, verdict
from app.results import PAPER_PREFIX

validation = importlib.import_module("app.report.validation")   # the package's name is a function


@pytest.fixture
def claimed(monkeypatch):
    """The rule at the resolution the model claims (NEAR), not the record's measured one."""
    monkeypatch.setattr(validation, "resolution", lambda: NEAR)


@pytest.mark.parametrize("model, paper, want", [
    (NEAR + 0.01, None, AGREES), (NEAR, None, CLOSE), (-NEAR, None, CLOSE),
    (-NEAR - 0.01, None, DISAGREES),                        # an ordering only: within is close
    (0.15, 0.15, AGREES), (0.15, 0.05, AGREES),             # the paper's sign, beyond NEAR
    (0.05, 0.05, CLOSE), (-0.05, 0.05, CLOSE), (0.0, 0.0, CLOSE),
    (0.05, 0.15, DISAGREES),                                # within, the paper beyond: not close
    (-0.15, 0.15, DISAGREES), (0.20, 0.0, DISAGREES),       # the paper calls them close
    (-0.20, -0.20, AGREES), (0.20, -0.20, DISAGREES),
    (float("nan"), None, DISAGREES)])
def test_the_rule_at_its_edges(model, paper, want):
    assert verdict(model, paper, near=NEAR) == want


@pytest.mark.parametrize("a, b, paper", [(1.0, 1.3, 0.2), (1.0, 1.05, None), (2.0, 1.0, 0.0),
                                         (1.0, 1.12, 0.05)])
def test_the_rule_is_symmetric(a, b, paper):
    assert gap(a, b) == pytest.approx(-gap(b, a))
    assert verdict(gap(a, b), paper) == verdict(gap(b, a), None if paper is None else -paper)
    assert gap(9.0, 10.0) == pytest.approx(0.1)              # relative to the larger


def table_rows(shade_ms):
    """zbin's optimization-table rows with the PS4's modelled shading ms of each variant."""
    return [{"study": PAPER_PREFIX + "zbin_table", "technique": "zbin", "scene": "hangar",
             "zbin_variant": k, "lights": 256, "visible": 230, "width": 1920, "height": 1080,
             "evaluated_pp": 10.0, "model_ps4_shade_ms": ms, "model_ps4_bound": "alu"}
            for k, ms in enumerate(shade_ms)]


def test_claims_are_judged_through_the_accessor(claimed):
    rows = table_rows([2.0, 1.74, 2.0, 1.74])          # z-binning saves 13%: the slides 15%
    got = {c.id: c for c in claims(rows)}
    assert got["hangar/zbin"].verdict == AGREES
    assert got["zbin_table/zbin/2<0"].verdict == DISAGREES      # scalarized: no gain
    assert got["zbin_table/zbin/1<0"].verdict == AGREES
    # the same claims under another model: z-binning saving 5% is within NEAR, the slides'
    # 15% beyond it
    other = lambda r, key, part: modelled_ms(r, key, part) * (0.95 / 0.87 if r["zbin_variant"] % 2 else 1.0)
    again = {c.id: c for c in claims(rows, other)}
    assert again["hangar/zbin"].verdict == DISAGREES
    assert set(again) == set(got)
    assert all(c.text and c.verdict in (AGREES, CLOSE, DISAGREES) for c in again.values())
    assert got["hangar/zbin"].markdown().endswith("**agrees**")


def test_the_rule_takes_the_records_measured_error_where_there_is_one():
    rec = gpu_record.record()
    assert rec is not None and rec.pair_factor > 1
    r = validation.resolution()
    assert r == pytest.approx(1 - 1 / rec.pair_factor) and r > NEAR
    assert verdict((r + NEAR) / 2) == CLOSE and verdict((r + NEAR) / 2, near=NEAR) == AGREES
    text = validation.rule()
    assert f"{r:.0%}" in text and "measured error" in text and rec.renderer in text
