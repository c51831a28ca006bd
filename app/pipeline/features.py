"""Simulate only the effects a scene calls for.

The feature set of a frame is the set of light types its visible lights contain.  It
generates `features.glsl`, the only light-type code the shading passes compile: a scene
without spot lights compiles no cone test, a scene of spots only tests no type.  The
same set goes into the dump's meta.

Per tile (`--feature-variants`, app/techniques/variants.py) the same idea one step finer, as
HDRP's deferred feature variants do: a tile's feature mask (FEATURE_BITS below, generated
into GLSL) names the shapes its lists hold, whether a pixel of it is specular and, for
hybrid, its cell kinds; `mask_features(mask)` is the feature set its program compiles, a
tile of empty lists compiling no light code at all.

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
    return (layouts.glsl_declarations() + layouts.glsl_defines(unit_defines(), suffix="")
            + layouts.glsl_defines(feature_bit_defines()))


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


# A tile's feature mask (glsl/variant_*.comp, generated as FEATURE_<NAME>_BIT): bit t is light
# shape t (LIGHT_TYPES order), then specular, then hybrid's cell kinds (structure: a one-node
# cell is read as a list, a larger one as a tree; neither: no shading pixel reads a cell).
FEATURE_BITS = {**{t: 1 << k for k, t in enumerate(LIGHT_TYPES)},
                SPECULAR: 1 << len(LIGHT_TYPES), "list_cells": 1 << (len(LIGHT_TYPES) + 1),
                "tree_cells": 1 << (len(LIGHT_TYPES) + 2)}
SHAPE_MASK = sum(1 << k for k in range(len(LIGHT_TYPES)))
CELL_KIND_SHIFT = len(LIGHT_TYPES) + 1           # (mask >> shift) & 3: 1 lists, 2 trees, 3 both
MASKS = 2 * max(FEATURE_BITS.values())           # masks 0 .. MASKS-1 (128)


def feature_bit_defines() -> dict[str, int]:
    """FEATURE_<NAME>_BIT for GLSL, FEATURE_SHAPES (the shape bits) and FEATURE_MASKS."""
    out = {f"FEATURE_{k.upper()}_BIT": v for k, v in FEATURE_BITS.items()}
    return dict(out, FEATURE_SHAPES=SHAPE_MASK, FEATURE_MASKS=MASKS)


def mask_of(features: tuple[str, ...]) -> int:
    """The mask of a feature set (names of FEATURE_BITS)."""
    return sum(FEATURE_BITS[f] for f in features)


def mask_features(mask: int) -> tuple[str, ...]:
    """The feature set a tile of `mask` compiles: its shapes (none for empty lists), then
    specular when one of its pixels is."""
    names = tuple(t for t in LIGHT_TYPES if mask & FEATURE_BITS[t])
    return names + ((SPECULAR,) if mask & FEATURE_BITS[SPECULAR] else ())


def mask_label(mask: int) -> str:
    """'point+box, specular' / 'empty' / 'point, lists+trees': a mask in words."""
    shapes = "+".join(t for t in LIGHT_TYPES if mask & FEATURE_BITS[t]) or "empty"
    extra = [SPECULAR] if mask & FEATURE_BITS[SPECULAR] else []
    kinds = [k for k in ("list_cells", "tree_cells") if mask & FEATURE_BITS[k]]
    if kinds:
        extra.append("+".join(k.split("_")[0] + "s" for k in kinds))
    return ", ".join([shapes] + extra)


@lru_cache(maxsize=None)   # the same text objects every frame: cache keys hash once
def features_glsl(features: tuple[str, ...]) -> str:
    """light_affects_as / light_radiance_as for exactly the shapes present, each taking the
    light's type: one type test per shape but the last (a scene of one shape tests no type),
    and a caller that passes a constant type (a per-type loop) gets that shape's code alone
    once the compiler inlines and folds.  HAS_<SHAPE> 1 for each shape compiled, 0 for the
    others; SPECULAR 1 only when some surface has a specular material (material.glsl).
    No shape at all (a feature variant's tile whose lists are empty): no light code, every
    light affects nothing (its loops run over empty lists, so none is met)."""
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
        if present:
            out.append(f"    return {SHAPES[present[-1]][col]};\n}}")
        else:
            out.append(("    return false;" if col == 1 else "    l = vec3(0.0); return vec3(0.0);") + "\n}")
    return "\n".join(out) + "\n"


def virtual_files(features: tuple[str, ...]) -> dict[str, str]:
    return {"generated.glsl": generated_glsl(), "features.glsl": features_glsl(features)}
