"""Every value that crosses into GLSL is written once in Python and generated into the
shaders' text: read back through a real driver, each generated constant is Python's."""
from __future__ import annotations

import re

import numpy as np
import pytest

from app.pipeline import features, gbuffer
from app.techniques import REGISTRY, fptl, hybrid, tiled
from cpu_prep import layouts


def read_back(gl, text: str, names, head: str = "") -> dict[str, int]:
    """{name: value} of uint(NAME) for each of `names`, as a compute shader compiled after
    `head` (defines) and `text` sees them."""
    names = list(names)
    body = [f"    outv[{k}] = uint({n});" for k, n in enumerate(names)]
    src = "\n".join(["#version 430", head, "layout(local_size_x = 1) in;", text,
                     "layout(std430, binding = 0) writeonly buffer Out { uint outv[]; };",
                     "void main() {", *body, "}"])
    prog = gl.compute_shader(src)
    out = gl.buffer(reserve=4 * len(names))
    out.bind_to_storage_buffer(0)
    prog.run(1)
    got = np.frombuffer(out.read(), np.uint32).tolist()
    prog.release()
    out.release()
    return dict(zip(names, got))


def defined(text: str) -> set[str]:
    return set(re.findall(r"^#define (\w+) ", text, re.M))


def test_generated_glsl_holds_the_constants_and_units(gl):
    want = dict(layouts.glsl_constants(), **gbuffer.unit_defines(), **features.feature_bit_defines())
    text = features.generated_glsl()
    assert defined(text) == set(want)
    assert read_back(gl, text, want) == want
    bits = features.FEATURE_BITS
    assert want["FEATURE_SPECULAR_BIT"] == bits["specular"] and want["FEATURE_MASKS"] == features.MASKS
    assert features.MASKS == 2 * max(bits.values()) and len(set(bits.values())) == len(bits)
    assert want["G_POSITION_UNIT"] == gbuffer.TEXTURE_UNITS["g_position"]
    assert (want["CASE_LIST"], want["CASE_TREE"], want["CASE_MIXED"]) == \
        (layouts.CASE_LIST, layouts.CASE_TREE, layouts.CASE_LIST | layouts.CASE_TREE)


def test_techniques_constants_are_theirs(gl):
    assert read_back(gl, REGISTRY["hybrid"].glsl["hybrid_cells.glsl"], ["CELL_TREE_BIT"]) == \
        {"CELL_TREE_BIT": int(hybrid.CELL_TREE_BIT)}
    assert read_back(gl, REGISTRY["tiled"].glsl["tiled_lists.glsl"], ["TILE_OVERFLOW"]) == \
        {"TILE_OVERFLOW": tiled.OVERFLOW}
    text = REGISTRY["fptl"].glsl["fptl_structs.glsl"]
    want = {"FPTL_TILE": fptl.TILE, "FPTL_CAP": fptl.LIST_CAP, "FPTL_BATCH": fptl.COARSE_BATCH,
            "FPTL_SPILLED": fptl.FLAG_SPILLED, "FPTL_POOL_FULL": fptl.FLAG_POOL_FULL}
    assert read_back(gl, text, want) == want


@pytest.mark.parametrize("bits", fptl.INDEX_FORMATS)
def test_fptl_list_format_is_the_decoders(gl, bits):
    """fptl_format.glsl per index width: the words decode_lists / decode_state read."""
    text = REGISTRY["fptl"].glsl["fptl_format.glsl"]
    k = np.arange(8)
    want = {"FPTL_LIST_WORDS": fptl.list_words(bits), "FPTL_HEAD_WORDS": fptl.head_words(bits),
            "FPTL_PER_WORD": 32 // bits, "FPTL_INDEX_MASK": (1 << bits) - 1,
            "FPTL_BLOCK_COUNT_SHIFT": fptl.BLOCK_COUNT_SHIFT,
            "FPTL_COUNT_WORD_STATE_SHIFT": fptl.COUNT_WORD_STATE_SHIFT,
            "FPTL_SPILLED_SUM": sum(fptl.SPILLED_COUNTS),
            **{f"FPTL_SPILLED_COUNTS[{i}]": fptl.SPILLED_COUNTS[i] for i in k},
            **{f"FPTL_POOL_FULL_COUNTS[{i}]": fptl.POOL_FULL_COUNTS[i] for i in k}}
    assert read_back(gl, text, want, f"#define FPTL_INDEX_BITS {bits}") == want
