"""The wave API of glsl/wave.glsl against numpy: the 64-lane group emulation exactly, and the
native subgroup path per subgroup (whatever size the driver reports)."""
import numpy as np
import pytest

from app.pipeline import gl as glmod
from app.pipeline.shaders import Source

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
#if WAVE_NATIVE
    outv[o + 0] = waveAllMin(v);
    outv[o + 1] = waveAllMax(v);
    outv[o + 2] = waveActiveAllTrue(v > 1u) ? 1u : 0u;
    outv[o + 3] = waveActiveAnyTrue(v == 11u) ? 1u : 0u;
    outv[o + 4] = waveReadFirstLane(v);
    uvec2 b = waveBallot(p);
    outv[o + 5] = b.x; outv[o + 6] = b.y;
    outv[o + 7] = gl_SubGroupSizeARB;
    outv[o + 8] = gl_SubGroupInvocationARB;
    outv[o + 9] = waveAllBitOr(1u << (v % 32u));
    // a uniform loop with a per-lane value (the zbin shader's merged word loop)
    uint acc = 0u;
    for (uint k = 0u; k < 3u; ++k) acc += bitCount(waveAllBitOr(lane < 5u ? k << lane : 0u));
    outv[o + 10] = acc;
#else
    outv[o + 0] = groupAllMin(v);
    outv[o + 1] = groupAllMax(v);
    outv[o + 2] = groupActiveAllTrue(v > 1u) ? 1u : 0u;
    outv[o + 3] = groupActiveAnyTrue(v == 11u) ? 1u : 0u;
    outv[o + 4] = groupReadFirstLane(v);
    uvec2 b = groupBallot(p);
    outv[o + 5] = b.x; outv[o + 6] = b.y;
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

def run(gl, native: bool) -> np.ndarray:
    ext = glmod.NATIVE_WAVE_EXTENSIONS if native else ()
    text = Source("t.comp", {"t.comp": MAIN}).text({"WAVE_NATIVE": int(native)}, ext)
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
    if not glmod.limits().native_ballot:
        pytest.fail("driver lacks GL_ARB_shader_ballot: the native path cannot be checked")
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
