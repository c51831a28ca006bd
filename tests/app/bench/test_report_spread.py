"""What the report may call a finding: a timing difference beyond the measured spread."""
from app.report.spread import Spread, below, lowest, lowest_phrase, ratio_phrase


def test_below_needs_disjoint_ranges_and_two_samples():
    a, b = Spread(1.0, 0.9, 1.1, 3), Spread(2.0, 1.5, 2.5, 3)
    assert below(a, b) and not below(b, a)
    assert not below(a, Spread(1.2, 1.05, 1.3, 3))           # overlapping ranges
    assert not below(Spread(1.0, 1.0, 1.0, 1), Spread(9.0, 9.0, 9.0, 1))   # one sample each


def test_lowest_and_phrases():
    c = {16: Spread(1.0, 0.9, 1.1, 3), 32: Spread(1.05, 1.0, 1.2, 3), 64: Spread(3.0, 2.8, 3.2, 3)}
    best, rivals = lowest(c)
    assert best == 16 and rivals == [32]
    assert "within spread of tile 32" in lowest_phrase(c, "GPU", lambda v: f"tile {v}")
    del c[32]
    assert "is lowest at tile 16" in lowest_phrase(c, "GPU", lambda v: f"tile {v}")
    r = Spread(2.0, 1.8, 2.2, 3).ratio(Spread(1.0, 0.9, 1.1, 3))
    assert r.lo < r.med < r.hi and "higher beyond spread" in ratio_phrase(r)
    assert "within spread" in ratio_phrase(Spread(1.0, 0.9, 1.1, 3).ratio(Spread(1.0, 0.95, 1.05, 3)))
    assert "one sample" in ratio_phrase(Spread(2.0, 2.0, 2.0, 1))
