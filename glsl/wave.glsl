// Subgroup-style wave API (DESIGN "Subgroup-style emulation").
//
// group*: the portable emulation, one 64-lane wave = one 8x8 workgroup, through shared
//   memory.  Every invocation of the group must call each function (they hold barriers), so
//   loops that use them keep inactive lanes iterating with their work masked.  Their results
//   are uniform over the workgroup, so they may guard further barriers.
// wave*:  the same calls on the native subgroup (GL_ARB_shader_ballot + group_vote) when
//   WAVE_NATIVE is 1, else the group* emulation.  Native results are uniform per subgroup
//   only: never guard a barrier() with them.  Either way the image is the same: the API
//   only steers which (equivalent) loop runs.
// define: WAVE_NATIVE

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

#if WAVE_NATIVE
bool waveActiveAllTrue(bool b) { return allInvocationsARB(b); }
bool waveActiveAnyTrue(bool b) { return anyInvocationARB(b); }
uint waveReadFirstLane(uint v) { return readFirstInvocationARB(v); }
uvec2 waveBallot(bool b) { return unpackUint2x32(ballotARB(b)); }
uint waveAllMin(uint v) {
    uint r = v;
    uvec2 m = waveBallot(true);
    for (uint w = 0u; w < 2u; ++w)
        for (uint bits = m[w]; bits != 0u; bits &= bits - 1u)
            r = min(r, readInvocationARB(v, w * 32u + uint(findLSB(bits))));
    return r;
}
uint waveAllMax(uint v) { return ~waveAllMin(~v); }
// ARB_shader_ballot has no OR reduction: read each active lane once (as waveAllMin), unless
// every lane holds the same value (one vote; lanes of one screen tile often do).
uint waveAllBitOr(uint v) {
    uint first = readFirstInvocationARB(v);
    if (allInvocationsARB(v == first)) return first;
    uint r = 0u;
    uvec2 m = waveBallot(true);
    for (uint w = 0u; w < 2u; ++w)
        for (uint bits = m[w]; bits != 0u; bits &= bits - 1u)
            r |= readInvocationARB(v, w * 32u + uint(findLSB(bits)));
    return r;
}
#else
bool waveActiveAllTrue(bool b) { return groupActiveAllTrue(b); }
bool waveActiveAnyTrue(bool b) { return groupActiveAnyTrue(b); }
uint waveReadFirstLane(uint v) { return groupReadFirstLane(v); }
uvec2 waveBallot(bool b) { return groupBallot(b); }
uint waveAllMin(uint v) { return groupAllMin(v); }
uint waveAllMax(uint v) { return groupAllMax(v); }
uint waveAllBitOr(uint v) { return groupAllBitOr(v); }
#endif
