"""cpu_prep.stochastic: the per-light draw (deterministic, in (0, 1], keyed by scene id), the
ranges (the cutoff study's radius at xi = 1, longer below), and the estimator in float64:
unbiased against the unbounded falloff, with the closed-form variance."""
import numpy as np

from app.bench.cutoff import cutoff_lights
from cpu_prep import stochastic as st
from scenes.model import LIGHT_BOX, LIGHT_POINT, LIGHT_SPOT, make_lights


def _lights(n=50, seed=4):
    rng = np.random.default_rng(seed)
    L = make_lights(n)
    L["type"] = rng.choice([LIGHT_POINT, LIGHT_SPOT, LIGHT_BOX], n, p=[0.6, 0.3, 0.1])
    L["position"] = rng.uniform(-20, 20, (n, 3))
    L["intensity"] = rng.uniform(0.5, 20.0, n)
    L["color"] = rng.uniform(0.2, 1.0, (n, 3))
    L["radius"] = 3.0
    L["length"] = rng.uniform(0, 4, n)
    return L


def test_the_draw_is_deterministic_in_its_range_and_keyed_by_scene_id():
    a = st.draw_xi(5000, seed=7, frame=3)
    assert np.array_equal(a, st.draw_xi(5000, seed=7, frame=3))
    assert np.array_equal(a[:100], st.draw_xi(100, seed=7, frame=3))    # by id, not by count
    assert (a > 0).all() and (a <= 1).all()
    for other in (st.draw_xi(5000, 8, 3), st.draw_xi(5000, 7, 4)):
        assert np.mean(a == other) < 0.01
    # uniform: mean, variance and a Kolmogorov-Smirnov distance well inside 5000 draws' spread
    assert abs(a.mean() - 0.5) < 0.02 and abs(a.var() - 1 / 12) < 0.005
    s = np.sort(a)
    assert np.abs(s - np.arange(1, len(s) + 1) / len(s)).max() < 1.63 / np.sqrt(len(s))


def test_at_xi_one_the_range_is_the_cutoff_studys_radius_and_longer_below():
    L = _lights()
    L["type"] = LIGHT_POINT
    t = 1 / 64
    alpha = st.alphas(L, t)
    far = np.full(len(L), 1e9)
    r1 = st.ranges(alpha, np.ones(len(L)), far)
    cut = cutoff_lights(L, t)
    kept = ~np.isnan(r1)
    assert kept.sum() == len(cut)
    assert np.allclose(r1[kept], cut["radius"], rtol=1e-6)
    xi = st.draw_xi(len(L), 1)
    r = st.ranges(alpha, xi, far)
    assert (r[kept] >= r1[kept]).all()
    # alpha xi >= 1: the light reaches nothing this frame; the clamp bounds the rest
    assert np.isnan(st.ranges(np.array([2.0]), np.array([0.5]), np.array([5.0])))[0]
    assert st.ranges(np.array([1e-6]), np.array([1e-6]), np.array([5.0]))[0] == 5.0


def test_stochastic_lights_leave_boxes_exact_and_name_the_dark_ones():
    L = _lights()
    L["intensity"][0], L["type"][0] = 0.0, LIGHT_POINT        # dark: alpha inf
    out, alpha, dark = st.stochastic_lights(L, 1 / 16, 3, 0, np.zeros(3), 100.0)
    box = L["type"] == LIGHT_BOX
    assert (alpha[box] == 0).all() and (alpha[~box] > 0).all()
    assert np.array_equal(out["radius"][box], L["radius"][box])
    assert 0 in dark and not box[dark].any()
    assert np.array_equal(out["position"], L["position"])     # ids and shapes unchanged
    lit = ~box & ~np.isin(np.arange(len(L)), dark)
    assert (out["radius"][lit] > 0).all()


def test_the_estimator_is_unbiased_with_the_closed_form_variance():
    """One light, many distances, 200,000 draws: E[f~] = f = 1/(d^2+1) and
    Var = f (alpha - f)+ (= u^2 (alpha/f - 1)+ with u = f), each within 5 standard errors."""
    alpha, n = 0.05, 200_000
    d = np.array([0.0, 1.0, 3.0, 4.3, 6.0, 10.0, 30.0])
    f = 1.0 / (d * d + 1.0)
    xi = st.draw_xi(n, seed=11)
    r = st.ranges(np.full(n, alpha), xi, np.full(n, 1e9))
    kept = d[None, :] <= np.nan_to_num(r, nan=-1.0)[:, None]
    est = np.where(kept, np.maximum(alpha, f), 0.0)
    var = st.variance(f[:, None], f[:, None], np.array([alpha]))
    assert np.allclose(var, np.maximum(f * (alpha - f), 0.0))
    se = np.sqrt(var / n)
    assert (np.abs(est.mean(0) - f) <= 5 * se + 1e-12).all(), (est.mean(0), f)
    close = var > 0
    assert np.allclose(est.var(0)[close], var[close], rtol=0.05)
    assert (est.min(0)[~close] == f[~close]).all()           # f >= alpha: always evaluated, f~ = f
