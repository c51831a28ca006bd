"""The wave API of glsl/wave.glsl against numpy: the 64-lane group emulation exactly, and the
native subgroup path per subgroup (whatever size the driver reports)."""
import numpy as np
import pytest

from app.pipeline import gl as glmod
from app.pipeline.shaders import Source

LANES = 64
MAIN = """#version 430
// define: WAVE_NATIVE
layout(local_size_x = 8, local_size_y = 8) in;
#include "wave.glsl"
layout(std430, binding = 0) writeonly buffer Out { uint outv[]; };
void main() {
    uint lane = gl_LocalInvocationIndex;
    uint v = (lane * 37u + 11u) % 97u;
    bool p = lane % 3u == 0u;
    uint o = lane * 16u;
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
#endif
}
"""

def run(gl, native: bool) -> np.ndarray:
    ext = glmod.NATIVE_WAVE_EXTENSIONS if native else ()
    text = Source("t.comp", {"t.comp": MAIN}).text({"WAVE_NATIVE": int(native)}, ext)
    prog = gl.compute_shader(text)
    out = gl.buffer(reserve=LANES * 16 * 4)
    out.bind_to_storage_buffer(0)
    prog.run(1)
    got = np.frombuffer(out.read(), np.uint32).reshape(LANES, 16).astype(np.int64)
    prog.release(), out.release()
    return got


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
              13: sum(max(k * l for l in range(10)) for k in range(3))}
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
