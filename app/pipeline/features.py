"""Simulate only the effects a scene calls for.

The feature set of a frame is the set of light types its visible lights contain.  It
generates `features.glsl`, the only light-type code the shading passes compile: a scene
without spot lights compiles no cone test, a scene of spots only tests no type.  The
same set goes into the dump's meta.

Also generates `generated.glsl`: the GPU structs, limits, light type ids and wave case bits
(from cpu_prep.layouts) and the G-buffer's texture units (app.pipeline.gbuffer): every value
both sides read, written once in Python.  Buffer binding points are not here: the renderer
numbers each pass's buffers.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from cpu_prep import layouts
from scenes.model import LIGHT_TYPES

from .gbuffer import unit_defines


@lru_cache(maxsize=None)
def generated_glsl() -> str:
    return layouts.glsl_declarations() + layouts.glsl_defines(unit_defines(), suffix="")


def feature_set(light_types: np.ndarray, specular: bool = False) -> tuple[str, ...]:
    """Light type names present (type-id order), then "specular" when some surface has a
    specular material; a frame with no lights gets ('point',), whose code is never reached,
    so that the program still compiles."""
    present = sorted(set(np.unique(light_types).tolist()))
    names = tuple(LIGHT_TYPES[t] for t in present if t < len(LIGHT_TYPES))
    return (names or ("point",)) + ((SPECULAR,) if specular else ())


# Per light shape: the include its code lives in, its "affects" test and its radiance, as
# GLSL expressions of (GpuLight L, vec3 d = P - position, float d2 = dot(d, d), vec3 N).
SHAPES = {
    "point": ("", "sphere_reaches(L, d2)", "lambert(L, d, d2, N, l)"),
    "spot": ("light_spot.glsl", "sphere_reaches(L, d2) && spot_cone_contains(L, d, d2)",
             "lambert(L, d, d2, N, l) * spot_falloff(L, d, d2)"),
    "capsule": ("light_capsule.glsl", "capsule_contains(L, d)", "capsule_radiance(L, d, N, l)"),
    "box": ("light_box.glsl", "box_contains(L, d)", "box_radiance(L, d, N, l)"),
}
assert tuple(SHAPES) == LIGHT_TYPES
SPECULAR = "specular"         # a material feature: some surface has GGX specular


@lru_cache(maxsize=None)   # the same text objects every frame: cache keys hash once
def features_glsl(features: tuple[str, ...]) -> str:
    """light_affects_as / light_radiance_as for exactly the shapes present, each taking the
    light's type: one type test per shape but the last (a scene of one shape tests no type),
    and a caller that passes a constant type (a per-type loop) gets that shape's code alone
    once the compiler inlines and folds.  HAS_<SHAPE> 1 for each shape compiled, 0 for the
    others; SPECULAR 1 only when some surface has a specular material (material.glsl)."""
    present = [t for t in LIGHT_TYPES if t in features]
    out = [f"#define SPECULAR {int(SPECULAR in features)}"]
    out += [f"#define HAS_{t.upper()} {int(t in present)}" for t in LIGHT_TYPES]
    out += ['#include "light_window.glsl"']
    out += [f'#include "{SHAPES[t][0]}"' for t in present if SHAPES[t][0]]
    for fn, col, ret in (("light_affects_as", 1, "bool"), ("light_radiance_as", 2, "vec3")):
        extra = ", vec3 N, out vec3 l" if col == 2 else ""
        out.append(f"{ret} {fn}(GpuLight L, vec3 d, float d2{extra}, uint type) {{")
        for t in present[:-1]:
            out.append(f"    if (type == LIGHT_{t.upper()}) return {SHAPES[t][col]};")
        out.append(f"    return {SHAPES[present[-1]][col]};\n}}")
    return "\n".join(out) + "\n"


def virtual_files(features: tuple[str, ...]) -> dict[str, str]:
    return {"generated.glsl": generated_glsl(), "features.glsl": features_glsl(features)}
