"""The cost model's instruction counts (app/model/spirv.py, app/model/counts.py): the
counting rule on a shader small enough to count by hand, the '// priced:' marks, and every
technique's programs pricing every step its replay issues."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from app.model import cost, counts, predict, spirv
from app.pipeline.renderer import Renderer
from app.pipeline.shaders import Source
from app.techniques import REGISTRY
from scenes import load_scene

SMALL = """#version 430
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer B { vec4 v[]; };
layout(std430, binding = 1) buffer C { uint n; float out_[]; };
float f(vec3 a, vec3 b) { return dot(a, b) + sqrt(a.x); }
void main() {
    float acc = 0.0;
    for (uint i = 0u; i < n; ++i) acc += f(v[i].xyz, v[i + 1u].xyz);
    out_[gl_GlobalInvocationID.x] = acc / 3.0 + float(gl_GlobalInvocationID.x % 7u);
}
"""


@pytest.fixture(scope="module")
def small():
    m = spirv.Module(spirv.disassemble(SMALL, "comp"))
    fn = m.functions["main"]
    return spirv.Counter(m), fn, next(b.label for b in fn.blocks.values() if b.loop)


def test_the_rule_counts_a_function_by_hand(small):
    c, _, _ = small
    # dot of vec3: 3, the add: 1, sqrt: a transcendental; the swizzle is free
    assert c.function("f") == spirv.Count(alu=4, trans=1)


def test_a_loop_iteration_by_hand(small):
    c, fn, header = small
    # i < n (the load of n, the compare, the branch), v[i] and v[i + 1] (the add, two
    # addresses, two vec4 loads), acc +=, ++i: 10; f priced apart, or its 4 + 1 in it
    assert c.loop_iteration(fn, header, frozenset({"f"})) == spirv.Count(alu=10)
    assert c.loop_iteration(fn, header, frozenset()) == spirv.Count(alu=14, trans=1)
    # main: the loop's body once (14), the store's address and the store, acc / 3.0 (a multiply
    # and a reciprocal), % 7 (an integer division), the conversion and the add; the
    # built-in's loads are registers
    assert c.function("main") == spirv.Count(alu=19, trans=2, idiv=1)


def test_an_opcode_without_a_rule_is_an_error(small):
    c, _, _ = small
    with pytest.raises(ValueError, match="no counting rule for OpFooBar"):
        c.instruction("FooBar", "%1", [], frozenset())


def test_a_mark_must_name_a_function_or_a_loop():
    bad = {"a.glsl": "#version 430\n// priced: light\nuint x = 1u;\n"}
    with pytest.raises(ValueError, match="before a function definition or a loop"):
        counts.annotations(Source("a.glsl", bad))
    typo = {"b.glsl": "#version 430\n// priced light\nvoid f() {}\n"}
    with pytest.raises(ValueError, match="not a priced mark"):
        counts.annotations(Source("b.glsl", typo))
    unknown = {"d.glsl": "#version 430\n// priced: ligth\nvoid f() {}\n"}
    with pytest.raises(ValueError, match="'ligth' is no priced kind"):
        counts.annotations(Source("d.glsl", unknown))
    ok = {"c.glsl": "#version 430\n// priced: node minus: g with: h\n// why\nvoid f() {\n"
                    "    // trips: 6\n    for (int i = 0; i < 6; ++i) {}\n}\n"}
    marks, trips = counts.annotations(Source("c.glsl", ok))
    assert marks == [("node", ("function", "f"), frozenset({"g"}), frozenset({"h"}))]
    assert trips == {("c.glsl", 6): 6}


# every technique at its defaults and the variants that change its shading code
RUNS = [(name, {}) for name in REGISTRY] + [
    *(("zbin", {"zbin_variant": v}) for v in range(4)),
    ("clustered", {"scalarize": True}), ("raster", {"cluster": True}),
    ("tiled", {"feature_variants": True})]


@pytest.fixture(scope="module")
def modelled(gl):
    """(technique, options) -> the figures of a small corridor frame (all four shapes)."""
    scene = load_scene("corridor", lights=96, seed=3)
    out = {}
    with Renderer(scene, (48, 32)) as r:
        for name, opts in RUNS:
            t = REGISTRY[name]
            res = r.render(t, 0, opts)
            out[(name, tuple(sorted(opts.items())))] = predict.frame_figures(r, t, res, opts)
    return out


def test_every_step_a_replay_issues_is_priced_by_its_program(modelled):
    """predict.modelled raises where a pass issues a kind its program has no mark for."""
    for key, figures in modelled.items():
        m = predict.modelled(figures)
        for g, v in m.items():
            assert v["shade"] > 0, (key, g)
        for passes in figures.values():
            for name, f in passes.items():
                assert f.ops, (key, name)


def _word(modelled, variant):
    return modelled[("zbin", (("zbin_variant", variant),))][32]["shade"].ops["word"]


def test_the_word_loop_costs_what_each_variant_compiles(modelled):
    """The base tile's word loop has no z-bin mask and no wave OR; the masked variant pays
    the mask, the scalarized ones the wave OR (a reduction), each counted from its program."""
    base, masked, scalar, both = (_word(modelled, v) for v in range(4))
    assert base[3] == 0 and masked[3] == 0                 # no reduction without scalarizing
    assert scalar[3] >= 1 and both[3] >= 1
    assert masked[0] > base[0] and both[0] > scalar[0]      # the z-bin mask's instructions


def test_shapes_cost_what_their_code_does(modelled):
    ops = modelled[("clustered", ())][32]["shade"].ops
    test = {s: sum(ops[f"test:{s}"]) for s in ("point", "spot", "capsule", "box")}
    assert test["point"] < test["spot"] and test["point"] < test["capsule"] < test["box"]
    assert sum(ops["ggx"]) > 0


RECORD = Path(__file__).with_name("counts_record.json")


def test_a_changed_count_comes_with_a_new_model_version(modelled):
    """The counts of every run above are recorded with the model version that priced them:
    a shader edit or a rule change that moves a count must bump cost.MODEL_VERSION (every
    modelled column in results.csv carries it); a run added (a new technique) is recorded
    under the same version.  LAB_WRITE_COUNTS=1 rewrites the record."""
    now = {" ".join([name, *(f"{k}={v}" for k, v in opts)]): {p: f.ops for p, f in fig[32].items()}
           for (name, opts), fig in sorted(modelled.items())}
    record = {"model_version": cost.MODEL_VERSION, "rule_version": counts.RULE_VERSION,
              "counts": now}
    if os.environ.get("LAB_WRITE_COUNTS"):
        RECORD.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    old = json.loads(RECORD.read_text())
    now = json.loads(json.dumps(now))
    moved = sorted(k for k in set(old["counts"]) & set(now) if old["counts"][k] != now[k])
    if moved:
        assert old["model_version"] != cost.MODEL_VERSION, (
            f"instruction counts changed ({', '.join(moved)}): bump cost.MODEL_VERSION, then "
            f"LAB_WRITE_COUNTS=1 pytest tests/app/model/test_counts.py")
        pytest.fail("counts and model version changed: record them (LAB_WRITE_COUNTS=1)")
    # a run added or gone (a new technique) moves no count a results row carries: recorded
    # under the same version
    assert set(old["counts"]) == set(now), (
        f"runs added or gone ({', '.join(sorted(set(old['counts']) ^ set(now)))}): record "
        f"them (LAB_WRITE_COUNTS=1 pytest tests/app/model/test_counts.py)")
    assert old["model_version"] == cost.MODEL_VERSION, "the record is of another model version"
