"""Simulate only the effects a scene calls for.

The feature set of a frame is the set of light types its visible lights contain.  It
generates `features.glsl`, the only light-type code the shading passes compile: a scene
without spot lights compiles no cone test, a scene of spots only tests no type.  The
same set goes into the dump's meta.

Also generates `generated.glsl`: the GPU structs, limits and light type ids (from
cpu_prep.layouts).  Binding points are not here: the renderer numbers each pass's buffers.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from cpu_prep import layouts
from scenes.model import LIGHT_TYPES


@lru_cache(maxsize=None)
def generated_glsl() -> str:
    return layouts.glsl_declarations()


def feature_set(light_types: np.ndarray) -> tuple[str, ...]:
    """Light type names present (type-id order); a frame with no lights gets ('point',),
    whose code is never reached, so that the program still compiles."""
    present = sorted(set(np.unique(light_types).tolist()))
    names = tuple(LIGHT_TYPES[t] for t in present if t < len(LIGHT_TYPES))
    return names or ("point",)


@lru_cache(maxsize=None)   # the same text objects every frame: cache keys hash once
def features_glsl(features: tuple[str, ...]) -> str:
    spot, point = "spot" in features, "point" in features
    out = ['#include "light_window.glsl"']
    if spot:
        out.append('#include "light_spot.glsl"')
    # light_affects: inside the sphere, and for spots inside the cone.
    out.append("bool light_affects(GpuLight L, vec3 d, float d2) {")
    out.append("#if !(defined(UNBOUNDED_FALLOFF) && UNBOUNDED_FALLOFF)")
    out.append("    if (!(d2 < L.pos_radius.w * L.pos_radius.w)) return false;")
    out.append("#endif")
    if spot and point:
        out.append("    if (L.id_type.y == LIGHT_SPOT) return spot_cone_contains(L, d, d2);")
    elif spot:
        out.append("    return spot_cone_contains(L, d, d2);")
    out.append("    return true;\n}")
    out.append("vec3 light_radiance(GpuLight L, vec3 d, float d2, vec3 N) {")
    if spot and point:
        out.append("    float f = L.id_type.y == LIGHT_SPOT ? spot_falloff(L, d, d2) : 1.0;")
        out.append("    return lambert(L, d, d2, N) * f;\n}")
    elif spot:
        out.append("    return lambert(L, d, d2, N) * spot_falloff(L, d, d2);\n}")
    else:
        out.append("    return lambert(L, d, d2, N);\n}")
    return "\n".join(out) + "\n"


def virtual_files(features: tuple[str, ...]) -> dict[str, str]:
    return {"generated.glsl": generated_glsl(), "features.glsl": features_glsl(features)}
