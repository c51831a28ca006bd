"""The light cutoff rule: each light's radius from the threshold where its unbounded falloff
becomes negligible, and the unbounded reference's lights (the `cutoff` study).  Beside the
cutoff levels the study runs stochastic light culling (cpu_prep.stochastic) at a few budgets
t = 1/N, which share the cutoff's parameter: at xi = 1 its range is the cutoff's radius."""
from __future__ import annotations

import numpy as np

from ..techniques.options import stochastic

# stochastic culling in the cutoff study: budgets N (t = 1/N), one draw (seed 0, frame 0),
# two list techniques (the quick report's few extra configurations: 2 cutoff scenes x 2
# budgets x 2 techniques, ~7 s on 2 cores at 320x180 with 2,048 lights, most of it the
# reference's frame of each draw, which their exactness needs; brute timed as well: ~20 s more)
STOCHASTIC_BUDGETS = (256, 4096)
STOCHASTIC_TECHNIQUES = ("tiled", "clustered")


def stochastic_draw(opts) -> tuple:
    """(budget, seed, frame) of options with stochastic culling on, else (): what a
    reference frame of the same draw is keyed by."""
    return stochastic(opts) or ()


def light_intensity(lights: np.ndarray) -> np.ndarray:
    """Peak radiance scale of each light: intensity x brightest colour channel."""
    return lights["intensity"].astype(np.float64) * lights["color"].astype(np.float64).max(1)


def cutoff_lights(lights: np.ndarray, cutoff: float, i_ref: float | None = None) -> np.ndarray:
    """The lights with each radius set where the unbounded falloff drops to `cutoff` of the
    reference intensity:

        I_i / (d^2 + 1) = t * I_ref   ->   radius_i = sqrt(I_i / (t * I_ref) - 1)

    I_ref is the brightest light of the scene (so t = 1/256 drops what stays below one 8-bit
    step of the brightest light's peak).  The radius grows as sqrt(I_i): the builtin scenes
    draw I_i ~ r_i^2, so the scene's many-small-few-large radius law is kept, scaled by
    sqrt(1/t).  A light never brighter than t * I_ref (I_i <= t * I_ref) affects nothing and
    is dropped."""
    inten = light_intensity(lights)
    i_ref = float(inten.max()) if i_ref is None and len(lights) else float(i_ref or 1.0)
    q = inten / (cutoff * i_ref) - 1.0
    keep = q > 1e-6
    out = lights[keep].copy()
    out["radius"] = np.sqrt(q[keep]).astype(np.float32)
    return out


def unbounded_lights(lights: np.ndarray, scene) -> np.ndarray:
    """The reference's lights: a radius past every point of the scene, so that the frustum
    cull keeps all of them (UNBOUNDED_FALLOFF ignores the radius when shading)."""
    lo, hi = scene.bounds()
    far = max(float(np.linalg.norm(hi - lo)), scene.camera.far)
    out = lights.copy()
    out["radius"] = np.float32(4.0 * far + 1.0)
    return out
