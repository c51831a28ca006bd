"""The wave API of glsl/wave.glsl against numpy: the 64-lane group emulation exactly, and the
native subgroup path the context selects (gl.limits().native_wave: ARB on llvmpipe, whose
subgroups have 8 lanes with AVX2) per subgroup, whatever size the driver reports, with lanes
that disagree, inactive lanes and a partial last subgroup.  The KHR path, which llvmpipe
lacks, is compiled by glslang in test_wave_khr.py."""
import numpy as np
import pytest

from app.pipeline import gl as glmod
from app.pipeline.shaders import ShaderError, Source

LANES = 64
COLS = 24
MAIN = """#version 430
// define: WAVE_NATIVE
layout(local_size_x = 8, local_size_y = 8) in;
#include "wave.glsl"
layout(std430, binding = 0) writeonly buffer Out { uint outv[]; };
void main() {
    uint lane = gl_LocalInvocationIndex;
    uint v = (lane * 37u + 11u) % 97u;
    bool p = lane % 3u == 0u;
    uint o = lane * 24u;
    // both paths: the emulation's wave* functions forward to its group* ones
    outv[o + 0] = waveAllMin(v);
    outv[o + 1] = waveAllMax(v);
    outv[o + 2] = waveActiveAllTrue(v > 1u) ? 1u : 0u;
    outv[o + 3] = waveActiveAnyTrue(v == 11u) ? 1u : 0u;
    outv[o + 4] = waveReadFirstLane(v);
    uvec4 b = waveBallot(p);
    outv[o + 5] = b.x; outv[o + 6] = b.y;
#if WAVE_NATIVE
    outv[o + 7] = waveLaneCount();
    outv[o + 8] = waveLaneIndex();
    outv[o + 9] = waveAllBitOr(1u << (v % 32u));
    // a uniform loop with a per-lane value (the zbin shader's merged word loop)
    uint acc = 0u;
    for (uint k = 0u; k < 3u; ++k) acc += bitCount(waveAllBitOr(lane < 5u ? k << lane : 0u));
    outv[o + 10] = acc;
#else
    outv[o + 7] = groupPrefixCountBits(p);
    outv[o + 8] = groupAllBitOr(1u << (lane % 32u));
    uvec4 r = groupReduce(v + 5u, v * 2u, lane, p ? 2u : 8u);
    outv[o + 9] = r.x; outv[o + 10] = r.y; outv[o + 11] = r.z; outv[o + 12] = r.w;
    // barriers inside a uniform loop with divergent work: every lane keeps iterating
    uint acc = 0u;
    for (uint k = 0u; k < 3u; ++k) acc += groupAllMax(lane < 10u ? k * lane : 0u);
    outv[o + 13] = acc;
    outv[o + 14] = waveAllBitOr(1u << (v % 32u));
    uint acc2 = 0u;
    for (uint k = 0u; k < 3u; ++k) acc2 += bitCount(waveAllBitOr(lane < 5u ? k << lane : 0u));
    outv[o + 15] = acc2;
    // many words OR-ed in one round of barriers; two rounds in a row reuse the shared words
    for (uint round = 0u; round < 2u; ++round) {
        groupOrWordsBegin(3u + round);
        groupOrWord(0u, 1u << ((lane + round) % 32u));
        if (lane == 7u) groupOrWord(2u, 5u + round);
        groupOrWord(2u + round, lane == 63u ? 0x80000000u : 0u);
        groupOrWordsEnd();
        for (uint k = 0u; k < 4u; ++k)
            outv[o + 16u + round * 4u + k] = k < 3u + round ? groupOrWordsResult(k) : 77u;
    }
#endif
}
"""

def native_path() -> int:
    """WAVE_NATIVE of the context's native path; a driver without one fails the test."""
    if not glmod.limits().native_wave:
        pytest.fail("driver has neither GL_KHR_shader_subgroup nor GL_ARB_shader_ballot: "
                    "the native wave path cannot be checked")
    return glmod.limits().wave_define


def run(gl, native: bool) -> np.ndarray:
    text = Source("t.comp", {"t.comp": MAIN}).text({"WAVE_NATIVE": native_path() if native else 0})
    prog = gl.compute_shader(text)
    out = gl.buffer(reserve=LANES * COLS * 4)
    out.bind_to_storage_buffer(0)
    prog.run(1)
    got = np.frombuffer(out.read(), np.uint32).reshape(LANES, COLS).astype(np.int64)
    prog.release(), out.release()
    return got


def _or(values) -> int:
    out = 0
    for x in np.asarray(values).tolist():
        out |= int(x)
    return out


def _or_loop(lanes) -> int:
    """The shaders' loop: sum over k of the bits of the OR of (k << lane) over lanes < 5."""
    return sum(bin(_or([k << int(l) for l in lanes if l < 5])).count("1") for k in range(3))


def inputs():
    lane = np.arange(LANES)
    return lane, (lane * 37 + 11) % 97, lane % 3 == 0


def test_group_emulation_matches_numpy(gl):
    got = run(gl, native=False)
    lane, v, p = inputs()
    mask = sum(1 << int(i) for i in lane[p])
    expect = {0: v.min(), 1: v.max(), 2: int((v > 1).all()), 3: int((v == 11).any()), 4: v[0],
              5: mask & 0xFFFFFFFF, 6: mask >> 32, 8: 0xFFFFFFFF,
              9: (v + 5).min(), 10: (v * 2).max(), 11: LANES - 1, 12: 2 | 8,
              13: sum(max(k * l for l in range(10)) for k in range(3)),
              14: _or(1 << (v % 32)), 15: _or_loop(lane),
              16: 0xFFFFFFFF, 17: 0, 18: 5 | 0x80000000, 19: 77,
              20: 0xFFFFFFFF, 21: 0, 22: 6, 23: 0x80000000}
    for col, want in expect.items():
        assert (got[:, col] == want).all(), (col, got[:, col], want)
    assert list(got[:, 7]) == [int(p[:i].sum()) for i in range(LANES)]


def test_native_subgroups_match_numpy_per_subgroup(gl):
    got = run(gl, native=True)
    lane, v, p = inputs()
    size = int(got[0, 7])
    assert size >= 1 and LANES % size == 0 and (got[:, 8] == lane % size).all()
    for start in range(0, LANES, size):
        sl = slice(start, start + size)
        sv, sp = v[sl], p[sl]
        mask = sum(1 << i for i in range(size) if sp[i])
        assert (got[sl, 0] == sv.min()).all() and (got[sl, 1] == sv.max()).all()
        assert (got[sl, 2] == int((sv > 1).all())).all() and (got[sl, 3] == int((sv == 11).any())).all()
        assert (got[sl, 4] == sv[0]).all()
        assert (got[sl, 5] == mask & 0xFFFFFFFF).all() and (got[sl, 6] == mask >> 32).all()
        assert (got[sl, 9] == _or(1 << (sv % 32))).all()
        assert (got[sl, 10] == _or_loop(lane[sl])).all()


# Every native wave function where only some lanes are active: 61 invocations (the last
# subgroup is partial at any size from 2 to 64), and per subgroup a case of which lanes
# take the branch, chosen from the lane's input (INACTIVE in the output's other columns).
PARTIAL_LANES, PARTIAL_COLS, INACTIVE = 61, 20, 0xDEAD
PARTIAL = """#version 430
// define: WAVE_NATIVE
layout(local_size_x = 61) in;
#include "wave.glsl"
layout(std430, binding = 0) writeonly buffer Out { uint outv[]; };
layout(std430, binding = 1) readonly buffer In { uvec4 inv[]; };   // active, value, key, predicate
void main() {
    uint lane = gl_LocalInvocationIndex;
    uint o = lane * 20u;
    uvec4 x = inv[lane];
    outv[o + 0] = waveLaneCount();
    outv[o + 1] = waveLaneIndex();
    for (uint k = 2u; k < 20u; ++k) outv[o + k] = 0xDEADu;
    if (x.x != 0u) {
        uint v = x.y, key = x.z;
        bool p = x.w != 0u;
        outv[o + 2] = waveAllMin(v);
        outv[o + 3] = waveAllMax(v);
        outv[o + 4] = waveAllBitOr(v);
        outv[o + 5] = waveAllBitOr(key);
        outv[o + 6] = waveAllBitOr(0x50u);          // one value on every lane: ARB's shortcut
        outv[o + 7] = waveReadFirstLane(v);
        uvec4 b = waveBallot(p);
        outv[o + 8] = b.x; outv[o + 9] = b.y; outv[o + 10] = b.z; outv[o + 11] = b.w;
        outv[o + 12] = waveActiveAllTrue(p) ? 1u : 0u;
        outv[o + 13] = waveActiveAnyTrue(p) ? 1u : 0u;
        outv[o + 14] = wavePrefixCountBits(p);
        outv[o + 15] = waveCompactValue(key);
        // lists.glsl's scalarized walk: a lane leaves once the first waiting lane has its key
        uint rounds = 0u;
        for (bool pending = true; pending; ++rounds)
            if (waveReadFirstLane(key) == key) pending = false;
        outv[o + 16] = rounds;
        outv[o + 17] = waveActiveAllTrue(true) ? 1u : 0u;
        outv[o + 18] = waveActiveAnyTrue(false) ? 1u : 0u;
        // a uniform loop of reductions over the active lanes (zbin's merged words)
        uint acc = 0u;
        for (uint k = 0u; k < 3u; ++k) acc += waveAllMax(v >> k) ^ waveAllMin(key + k);
        outv[o + 19] = acc;
    }
}
"""


def run_shader(gl, text: str, lanes: int, cols: int, inputs: np.ndarray | None = None) -> np.ndarray:
    prog = gl.compute_shader(text)
    out = gl.buffer(reserve=lanes * cols * 4)
    out.bind_to_storage_buffer(0)
    inp = None
    if inputs is not None:
        inp = gl.buffer(np.ascontiguousarray(inputs, np.uint32).tobytes())
        inp.bind_to_storage_buffer(1)
    prog.run(1)
    got = np.frombuffer(out.read(), np.uint32).reshape(lanes, cols).astype(np.int64)
    prog.release(), out.release()
    if inp is not None:
        inp.release()
    return got


def partial_inputs(size: int) -> np.ndarray:
    """(lanes, 4): active, value, key, predicate.  Subgroup g takes case g % 6 (the partial
    last one case 1): 0 all active; 1 its first lane inactive, inactive lanes holding values
    that would win every reduction; 2 only its last lane active; 3 none; 4 every other lane,
    one value and a true predicate on the active ones only; 5 all active, one value, no
    predicate.  Values span 0 .. 0xFFFFFFFF."""
    lane = np.arange(PARTIAL_LANES)
    x = np.zeros((PARTIAL_LANES, 4), np.int64)
    x[:, 1] = (lane * 2654435761 + 12345) % (1 << 32)
    x[:, 2] = (lane * 7) % 3 + 1
    x[:, 3] = (lane % 3 == 1)
    x[lane % 5 == 2, 1] = 0xFFFFFFFF
    count = -(-PARTIAL_LANES // size)
    for g in range(count):
        lanes = lane[g * size:(g + 1) * size]
        case = 1 if g == count - 1 and len(lanes) > 1 and len(lanes) < size else g % 6
        if case == 0:
            x[lanes, 0] = 1
        elif case == 1:
            x[lanes, 0] = 1
            x[lanes[0], 0] = 0
            x[lanes[0], 1] = 0                       # would be the min
            x[lanes[0], 2] = 0x80000000              # a bit no active lane has
        elif case == 2:
            x[lanes[-1], 0] = 1
        elif case == 4:
            on = lanes[(lanes - lanes[0]) % 2 == 0]
            off = lanes[(lanes - lanes[0]) % 2 == 1]
            x[on, 0], x[on, 1], x[on, 2], x[on, 3] = 1, 0x1234, 2, 1
            x[off, 1], x[off, 2], x[off, 3] = 0, 0x40000000, 0
        elif case == 5:
            x[lanes, 0], x[lanes, 1], x[lanes, 2], x[lanes, 3] = 1, 77, 1, 0
    return x


def expected_partial(x: np.ndarray, size: int) -> np.ndarray:
    want = np.full((PARTIAL_LANES, PARTIAL_COLS), INACTIVE, np.int64)
    lane = np.arange(PARTIAL_LANES)
    want[:, 0], want[:, 1] = size, lane % size
    for start in range(0, PARTIAL_LANES, size):
        act = [int(l) for l in lane[start:start + size] if x[l, 0]]
        if not act:
            continue
        v, key, p = x[act, 1], x[act, 2], x[act, 3].astype(bool)
        ballot = sum(1 << (l - start) for l, b in zip(act, p) if b)
        order = list(dict.fromkeys(key.tolist()))       # keys by their first lane
        acc = sum((int(v.max()) >> k) ^ int((key + k).min()) for k in range(3)) % (1 << 32)
        for i, l in enumerate(act):
            want[l, 2:] = [v.min(), v.max(), _or(v), _or(key), 0x50, v[0],
                           ballot & 0xFFFFFFFF, (ballot >> 32) & 0xFFFFFFFF,
                           (ballot >> 64) & 0xFFFFFFFF, ballot >> 96,
                           int(p.all()), int(p.any()), int(p[:i].sum()),
                           int((key[:i] == key[i]).sum()), order.index(key[i]) + 1, 1, 0, acc]
    return want


def test_native_waves_with_inactive_lanes_and_a_partial_subgroup(gl):
    text = Source("t.comp", {"t.comp": PARTIAL}).text({"WAVE_NATIVE": native_path()})
    size = int(run_shader(gl, text, PARTIAL_LANES, PARTIAL_COLS,
                          np.zeros((PARTIAL_LANES, 4)))[0, 0])
    assert 1 <= size <= 128 and size & (size - 1) == 0, size
    if glmod.limits().software:
        print(f"llvmpipe subgroup size {size}")
    x = partial_inputs(size)
    got = run_shader(gl, text, PARTIAL_LANES, PARTIAL_COLS, x)
    want = expected_partial(x, size)
    names = ["size", "lane", "min", "max", "or", "or key", "or uniform", "first", "ballot.x",
             "ballot.y", "ballot.z", "ballot.w", "all", "any", "prefix", "compact", "rounds",
             "all(true)", "any(false)", "loop"]
    bad = [(names[c], int(l), int(got[l, c]), int(want[l, c]))
           for c in range(PARTIAL_COLS) for l in np.flatnonzero(got[:, c] != want[:, c])]
    assert not bad, f"subgroup size {size}: (function, lane, got, want) {bad[:8]}"
    # every case was exercised: some subgroups fully, partly and not at all active
    active = [x[s:s + size, 0].sum() for s in range(0, PARTIAL_LANES, size)]
    assert 0 in active and size in active and any(0 < a < size for a in active), active


def test_loader_emits_each_native_paths_extensions():
    src = Source("t.comp", {"t.comp": PARTIAL})
    for value, exts in glmod.WAVE_EXTENSIONS.items():
        head = src.text({"WAVE_NATIVE": value}, ("GL_ARB_shader_ballot",)).splitlines()
        lines = [l for l in head if l.startswith("#extension")]
        assert lines == list(dict.fromkeys([f"#extension {e} : require"
                                            for e in ("GL_ARB_shader_ballot",) + exts]))
        assert head.index(lines[-1]) < head.index(f"#define WAVE_NATIVE {value}")
    assert not [l for l in src.text({"WAVE_NATIVE": 0}).splitlines() if l.startswith("#extension")]
    with pytest.raises(ShaderError, match="WAVE_NATIVE 3"):
        src.text({"WAVE_NATIVE": 3})


def test_native_path_selection():
    arb = {"GL_ARB_shader_ballot", "GL_ARB_gpu_shader_int64"}
    khr = arb | {"GL_KHR_shader_subgroup"}
    every = sum(glmod.KHR_FEATURES.values())
    stages = glmod.GL_COMPUTE_SHADER_BIT | glmod.GL_FRAGMENT_SHADER_BIT
    assert glmod.native_wave_path(khr, 32, stages | 0x1, every | 0x10) == "khr"
    assert glmod.native_wave_path(khr - arb, 64, stages, every) == "khr"
    assert glmod.native_wave_path(khr, 32, glmod.GL_COMPUTE_SHADER_BIT, every) == "arb"  # no fragment
    assert glmod.native_wave_path(khr, 32, stages, every & ~0x4) == "arb"   # no arithmetic
    assert glmod.native_wave_path(khr, 256, stages, every) == "arb"         # past a uvec4 ballot
    assert glmod.native_wave_path(khr, 0, stages, every) == "arb"           # the query failed
    assert glmod.native_wave_path(khr - arb, 32, 0, 0) == ""
    assert glmod.native_wave_path(arb, 0, 0, 0) == "arb"
    assert glmod.native_wave_path({"GL_ARB_shader_ballot"}, 0, 0, 0) == ""  # ballotARB is 64-bit
    assert glmod.WAVE_PATHS == {"": 0, "arb": glmod.WAVE_ARB, "khr": glmod.WAVE_KHR}


def test_limits_record_the_native_path(gl):
    lim = glmod.limits()
    exts = set(gl.extensions)
    assert lim.native_wave == glmod.native_wave_path(
        exts, *(glmod.gl_integers(0x9532, 0x9533, 0x9534) if "GL_KHR_shader_subgroup" in exts
                else (0, 0, 0)))
    assert lim.wave_define == glmod.WAVE_PATHS[lim.native_wave]
    if lim.software:     # llvmpipe (Mesa 22.3, docs/platform.md "Platform facts"): ARB, no KHR
        assert lim.native_wave == "arb" and lim.native_ballot and lim.subgroup_size == 0
    # the raw query: a name moderngl knows reads the same; a refused one reads 0, no error left
    assert glmod.gl_integers(0x0D33) == (int(gl.info["GL_MAX_TEXTURE_SIZE"]),)
    assert glmod.gl_integers(0x9532 if "GL_KHR_shader_subgroup" not in exts else 0xFFFF) == (0,)
    assert gl.error == "GL_NO_ERROR"
