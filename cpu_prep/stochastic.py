"""Stochastic light culling (Tokuyoshi & Harada, "Stochastic Light Culling", JCGT 5(1), 2016;
research: docs/research/accuracy_policies.md section 2): each light's range drawn by Russian
roulette on its falloff, once a frame, shared by every pixel.

With the lab's unbounded falloff f(d) = 1/(d^2 + 1) (glsl/light_window.glsl
UNBOUNDED_FALLOFF) and one uniform xi_i in (0, 1] per light:

    p_i(d) = min(f(d) / alpha_i, 1)                  evaluation probability
    light i is kept at d  <=>  p_i(d) >= xi_i  <=>  d <= r_i = sqrt(1 / (alpha_i xi_i) - 1)
    kept: f~ = f / p = max(alpha_i, f(d)); culled: 0  so E[f~] = f (unbiased)
    Var = (1/p - 1) f^2 = f (alpha_i - f)  where f < alpha_i, else 0

(the paper's f is 1/l^2 and its range 1/sqrt(alpha xi); the lab's f is finite at d = 0, hence
the -1).  alpha_i = t I_ref / I_i with the cutoff study's threshold t (app.bench.cutoff): at
xi = 1 the range is exactly that study's deterministic radius, and every xi < 1 extends it.
That is the paper's alpha_i = 2 pi eps_max / (E max I_i) with t I_ref standing for
2 pi eps_max / E.

Every culling structure takes r_i unchanged as the light's radius (the cull, the sort, the
pack, the bins, the trees, the proxies).  A light with alpha_i xi_i >= 1 reaches nothing this
frame.  Box lights have no distance falloff: they stay exact (alpha 0, radius unchanged).
The shader reads alpha_i from GPU_LIGHT right.w (0: the exact window falloff).
"""
from __future__ import annotations

import numpy as np

from scenes.model import LIGHT_BOX

XI_BITS = 24                   # xi = (k + 1) / 2^24, k the hash's top 24 bits: (0, 1]
MAX_BUDGET = 1 << 16           # budget N: t = 1/N, 1..65536 (the cutoff study's finest); 0: off
_M64 = np.uint64(0xFFFFFFFFFFFFFFFF)


def _splitmix(z: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser (Steele et al. 2014), uint64 wrapping."""
    with np.errstate(over="ignore"):
        z = (z + np.uint64(0x9E3779B97F4A7C15)) & _M64
        z = ((z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)) & _M64
        z = ((z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)) & _M64
    return z ^ (z >> np.uint64(31))


def draw_xi(n: int, seed: int, frame: int = 0) -> np.ndarray:
    """(n,) float64 xi_i in (0, 1] of scene lights 0..n-1 for (seed, frame): a hash of the
    scene id (not the depth-sorted index, so that the sort never changes a light's draw),
    the same on every machine and every call."""
    key = _splitmix(_splitmix(np.array([seed], np.uint64)) ^ np.uint64(frame))
    z = _splitmix(key ^ np.arange(n, dtype=np.uint64))
    return ((z >> np.uint64(64 - XI_BITS)).astype(np.float64) + 1.0) / float(1 << XI_BITS)


def alphas(lights: np.ndarray, t: float, i_ref: float | None = None) -> np.ndarray:
    """(n,) float64 alpha_i = t I_ref / I_i (I_i = intensity x brightest colour channel, as
    the cutoff study's; I_ref the brightest light); inf for a dark light, 0 for a box."""
    inten = lights["intensity"].astype(np.float64) * lights["color"].astype(np.float64).max(1) \
        if len(lights) else np.zeros(0)
    i_ref = float(inten.max()) if i_ref is None and len(lights) else float(i_ref or 1.0)
    with np.errstate(divide="ignore"):
        a = np.where(inten > 0, t * i_ref / np.where(inten > 0, inten, 1.0), np.inf)
    return np.where(lights["type"] == LIGHT_BOX, 0.0, a)


def ranges(alpha: np.ndarray, xi: np.ndarray, r_max: np.ndarray) -> np.ndarray:
    """(n,) float64 r_i = sqrt(1/(alpha_i xi_i) - 1), at most r_max (a range past every point
    the frame can see changes nothing: still unbiased); NaN where alpha_i xi_i >= 1 (the light
    reaches nothing this frame)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        q = 1.0 / (alpha * xi) - 1.0
    return np.where(q > 0, np.sqrt(np.minimum(np.where(q > 0, q, 0.0), r_max * r_max)), np.nan)


def stochastic_lights(lights: np.ndarray, t: float, seed: int, frame: int, eye: np.ndarray,
                      far: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lights, alpha float32, dark ids): a copy of the scene's lights with each point, spot
    and capsule light's radius its stochastic range for (seed, frame) at budget t, clamped to
    its distance from the eye plus 4 far plus half its segment (past every visible point);
    alpha_i per light (0 for boxes, unchanged); the ids that reach nothing this frame (their
    radius left for the caller to cull them: caps.without)."""
    out = lights.copy()
    alpha = alphas(lights, t)
    xi = draw_xi(len(lights), seed, frame)
    pos = lights["position"].astype(np.float64)
    r_max = np.linalg.norm(pos - np.asarray(eye, np.float64), axis=1) + 4.0 * far + 1.0 + \
        0.5 * lights["length"].astype(np.float64)
    r = ranges(alpha, xi, r_max)
    shaped = lights["type"] != LIGHT_BOX
    dark = np.nonzero(shaped & np.isnan(r))[0].astype(np.uint32)
    lit = shaped & ~np.isnan(r)
    out["radius"][lit] = r[lit].astype(np.float32)
    return out, np.where(shaped, alpha, 0.0).astype(np.float32), dark


def variance(u: np.ndarray, f: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """The estimator's per-pixel variance in closed form: lights are independent, so
    Var = sum_i u_i^2 (alpha_i / f_i - 1)+, u_i the light's unbounded contribution at the pixel
    (c_i f_i), f_i its unbounded falloff there.  u: (..., n) or (..., n, channels); f: (..., n)."""
    w = np.maximum(alpha / f - 1.0, 0.0)
    return (u * u * (w[..., None] if u.ndim > f.ndim else w)).sum(axis=f.ndim - 1)


__all__ = ["XI_BITS", "MAX_BUDGET", "draw_xi", "alphas", "ranges", "stochastic_lights", "variance"]
