// Subgroup-style wave API (docs/platform.md "Subgroup-style emulation").
//
// group*: the portable emulation, one 64-lane wave = one 8x8 workgroup, through shared
//   memory.  Every invocation of the group must call each function (they hold barriers), so
//   loops that use them keep inactive lanes iterating with their work masked.  Their results
//   are uniform over the workgroup, so they may guard further barriers.
// wave*:  the same calls on the native subgroup when WAVE_NATIVE is WAVE_KHR
//   (GL_KHR_shader_subgroup) or WAVE_ARB (GL_ARB_shader_ballot), else the group* emulation;
//   the shader loader emits the #extension lines of the value (app/pipeline/gl.py).  Native
//   results are uniform per subgroup only: never guard a barrier() with them.  Either way the
//   image is the same: the API only steers which (equivalent) loop runs.  No function assumes
//   a subgroup size (llvmpipe 8 here, NVIDIA 32, AMD 32 or 64): ballots are uvec4 on every
//   path (bit n = lane n; KHR subgroups reach 128 lanes, ARB's stop at 64), and only the
//   active lanes count (a partial subgroup, lanes that left a loop).
// A fragment shader (no workgroup) defines WAVE_FRAGMENT before the include: no group*
//   emulation then, and the wave* functions exist only on a native path.
// define: WAVE_NATIVE

#define WAVE_ARB 1
#define WAVE_KHR 2

#ifndef WAVE_FRAGMENT
shared uint wave_scalar;
shared uint wave_bits[2];
shared uint wave_reduce[4];

// Four reductions in one round of barriers (barriers dominate the emulation's cost):
// (min of a, max of b, max of c, OR of d) over the group.
uvec4 groupReduce(uint a_min, uint b_max, uint c_max, uint d_or) {
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        wave_reduce[0] = 0xFFFFFFFFu; wave_reduce[1] = 0u; wave_reduce[2] = 0u; wave_reduce[3] = 0u;
    }
    barrier();
    atomicMin(wave_reduce[0], a_min);
    atomicMax(wave_reduce[1], b_max);
    atomicMax(wave_reduce[2], c_max);
    atomicOr(wave_reduce[3], d_or);
    barrier();
    uvec4 r = uvec4(wave_reduce[0], wave_reduce[1], wave_reduce[2], wave_reduce[3]);
    barrier();
    return r;
}

uint groupAllMin(uint v) { return groupReduce(v, 0u, 0u, 0u).x; }
uint groupAllMax(uint v) { return groupReduce(0xFFFFFFFFu, v, 0u, 0u).y; }
uint groupAllBitOr(uint v) { return groupReduce(0xFFFFFFFFu, 0u, 0u, v).w; }

// groupAllBitOr of many words in one round of barriers (the emulation pays per round, not
// per word), in three calls every invocation makes:
//   groupOrWordsBegin(count);                      count <= WAVE_OR_WORDS, group-uniform
//   groupOrWord(k, v_k) for this lane's words;     any k < count, any order (skip zeros)
//   groupOrWordsEnd();  then groupOrWordsResult(k) is the OR of every lane's v_k, until the
//                       next groupOrWordsBegin
#define WAVE_OR_WORDS 32
shared uint wave_or_words[WAVE_OR_WORDS];
void groupOrWordsBegin(uint count) {
    barrier();
    if (gl_LocalInvocationIndex < count) wave_or_words[gl_LocalInvocationIndex] = 0u;
    barrier();
}
void groupOrWord(uint k, uint v) { if (v != 0u) atomicOr(wave_or_words[k], v); }
void groupOrWordsEnd() { barrier(); }
uint groupOrWordsResult(uint k) { return wave_or_words[k]; }

uvec2 groupBallot(bool b) {
    barrier();
    if (gl_LocalInvocationIndex < 2u) wave_bits[gl_LocalInvocationIndex] = 0u;
    barrier();
    uint lane = gl_LocalInvocationIndex;
    if (b) atomicOr(wave_bits[lane >> 5], 1u << (lane & 31u));
    barrier();
    uvec2 r = uvec2(wave_bits[0], wave_bits[1]);
    barrier();
    return r;
}

bool groupActiveAllTrue(bool b) { return groupAllMin(b ? 1u : 0u) == 1u; }
bool groupActiveAnyTrue(bool b) { return groupAllMax(b ? 1u : 0u) == 1u; }

uint groupReadFirstLane(uint v) {
    barrier();
    if (gl_LocalInvocationIndex == 0u) wave_scalar = v;
    barrier();
    uint r = wave_scalar;
    barrier();
    return r;
}

// Lanes below this one whose predicate is true.
uint groupPrefixCountBits(bool b) {
    uvec2 m = groupBallot(b);
    uint lane = gl_LocalInvocationIndex;
    uint lo = lane >= 32u ? bitCount(m.x) : bitCount(m.x & ((1u << lane) - 1u));
    uint hi = lane > 32u ? bitCount(m.y & ((1u << (lane - 32u)) - 1u)) : 0u;
    return lo + hi;
}

#endif  // WAVE_FRAGMENT

#if WAVE_NATIVE == WAVE_KHR
// GL_KHR_shader_subgroup (basic, vote, ballot, arithmetic): each call over the subgroup's
// active invocations.
bool waveActiveAllTrue(bool b) { return subgroupAll(b); }
bool waveActiveAnyTrue(bool b) { return subgroupAny(b); }
uint waveReadFirstLane(uint v) { return subgroupBroadcastFirst(v); }
uvec4 waveBallot(bool b) { return subgroupBallot(b); }
uint waveAllMin(uint v) { return subgroupMin(v); }
uint waveAllMax(uint v) { return subgroupMax(v); }
uint waveAllBitOr(uint v) { return subgroupOr(v); }
uint waveLaneCount() { return gl_SubgroupSize; }
uint waveLaneIndex() { return gl_SubgroupInvocationID; }
// bits of `mask` (a waveBallot) of the lanes below this one
uint waveCountBelow(uvec4 mask) { return subgroupBallotExclusiveBitCount(mask); }
#elif WAVE_NATIVE == WAVE_ARB
// GL_ARB_shader_ballot.  Votes are ballots too, not GL_ARB_shader_group_vote: its set of
// invocations is implementation-dependent (its spec), so it need not be the ballot's
// subgroup, and every function here must see the same lanes.
uvec4 waveBallot(bool b) { return uvec4(unpackUint2x32(ballotARB(b)), 0u, 0u); }
bool waveActiveAllTrue(bool b) { return ballotARB(b) == ballotARB(true); }
bool waveActiveAnyTrue(bool b) { return ballotARB(b) != uint64_t(0u); }
uint waveReadFirstLane(uint v) { return readFirstInvocationARB(v); }
// No reductions in ARB: read each active lane once (readInvocationARB of an inactive lane is
// undefined; the lane index, from a ballot, is uniform as the function wants).
uint waveAllMin(uint v) {
    uint r = v;
    uvec2 m = unpackUint2x32(ballotARB(true));
    for (uint w = 0u; w < 2u; ++w)
        for (uint bits = m[w]; bits != 0u; bits &= bits - 1u)
            r = min(r, readInvocationARB(v, w * 32u + uint(findLSB(bits))));
    return r;
}
uint waveAllMax(uint v) { return ~waveAllMin(~v); }
// as waveAllMin, unless every active lane holds the same value (lanes of one tile often do)
uint waveAllBitOr(uint v) {
    uint first = readFirstInvocationARB(v);
    uint64_t lanes = ballotARB(true);
    if (ballotARB(v == first) == lanes) return first;
    uint r = 0u;
    uvec2 m = unpackUint2x32(lanes);
    for (uint w = 0u; w < 2u; ++w)
        for (uint bits = m[w]; bits != 0u; bits &= bits - 1u)
            r |= readInvocationARB(v, w * 32u + uint(findLSB(bits)));
    return r;
}
uint waveLaneCount() { return gl_SubGroupSizeARB; }
uint waveLaneIndex() { return gl_SubGroupInvocationARB; }
uint waveCountBelow(uvec4 mask) {
    uvec2 m = mask.xy & unpackUint2x32(gl_SubGroupLtMaskARB);
    return uint(bitCount(m.x) + bitCount(m.y));
}
#elif !defined(WAVE_FRAGMENT)
bool waveActiveAllTrue(bool b) { return groupActiveAllTrue(b); }
bool waveActiveAnyTrue(bool b) { return groupActiveAnyTrue(b); }
uint waveReadFirstLane(uint v) { return groupReadFirstLane(v); }
uvec4 waveBallot(bool b) { return uvec4(groupBallot(b), 0u, 0u); }
uint waveAllMin(uint v) { return groupAllMin(v); }
uint waveAllMax(uint v) { return groupAllMax(v); }
uint waveAllBitOr(uint v) { return groupAllBitOr(v); }
uint waveLaneCount() { return 64u; }
uint waveLaneIndex() { return gl_LocalInvocationIndex; }
#endif

#if WAVE_NATIVE
// Lanes below this one whose predicate is true.
uint wavePrefixCountBits(bool b) { return waveCountBelow(waveBallot(b)); }

// The slides' WaveCompactValue: this lane's index among the active lanes holding the same
// value (0: the first of them; the caller's "one lane per value" work goes there).  A
// fragment's helper invocations are not counted: their writes are dropped, so one must never
// be the 0 of its value.  Native only (the lanes leave the loop one value at a time).
uint waveCompactValue(uint checkValue) {
#ifdef WAVE_FRAGMENT
    bool counted = !gl_HelperInvocation;
#else
    bool counted = true;
#endif
    uvec4 mask;
    for (;;) {                                        // loop until all active lanes removed
        uint firstValue = waveReadFirstLane(checkValue);
        mask = waveBallot(counted && firstValue == checkValue);   // the remaining active lanes
        if (firstValue == checkValue) break;          // exclude lanes with firstValue next time
    }
    return waveCountBelow(mask);
}
#elif !defined(WAVE_FRAGMENT)
uint wavePrefixCountBits(bool b) { return groupPrefixCountBits(b); }
#endif
