// A draw from a cell's list by its integer CDF words (cpu_prep/sampling.py): sample-list's
// samples and sample-ris's candidates.  Needs sampling.glsl (mass_probability).
layout(std430, binding = B_SAMPLE_CDF) readonly buffer SampleCdf { uint sample_cdf[]; };

// The first entry k of [first, first + n) with u < sample_cdf[k] (the last holds 2^31 > u);
// its probability from its own word and the one before.
uint draw_entry(uint first, uint n, uint u, out float p) {
    uint lo = first, hi = first + n - 1u;
    // priced: word
    while (lo < hi) {
        uint mid = (lo + hi) >> 1u;
        if (u < sample_cdf[mid]) hi = mid; else lo = mid + 1u;
    }
    p = mass_probability(sample_cdf[lo] - (lo > first ? sample_cdf[lo - 1u] : 0u));
    return lo;
}
