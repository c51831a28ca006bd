"""The GPU build's generic steps as frame-graph passes: an exclusive prefix sum and a stable
LSD radix sort of (key, value) pairs (app/gpu_build/build_scan.comp, app/gpu_build/build_sort.comp).

    scan   src[n] -> dst[n] exclusive sums:  blocks of 1024 | one group over the block sums
           (the grand total into a counter word) | each block adds its sum
    sort   per 8-bit digit, low first:  histogram per 256-pair block (digit-major) -> scan
           -> scatter, each pair after the earlier pairs of its block with its digit
           (stable: the CPU's LSD sort, cpu_prep/lights.py, gives the same order)

The pair count of a sort is a counter word made on the GPU (the visible lights, the
entries), so nothing is read back; its buffers are sized for `capacity` pairs.
"""
from __future__ import annotations

import numpy as np

from ..pipeline.passes import Buffer, Pass

GROUP = 256                 # app/gpu_build/build_common.glsl
SCAN_BLOCK = 4 * GROUP      # app/gpu_build/build_scan.comp
DIGIT_BITS = 8
NO_TOTAL = 0xFFFFFFFF
U32 = np.dtype(np.uint32)
MAX_GROUPS_X = 65535        # GL's minimum per axis: the 2D layout of large dispatches
# the counter words a scan's total goes to (prepare.py names them); every pass declares the
# whole buffer, since a smaller declaration would read back, or reallocate, fewer words
COUNTER_WORDS = 16


def groups(n_groups: int) -> tuple[int, int, int]:
    """A dispatch of n_groups groups laid out in 2D (build_common.glsl group_index)."""
    n = max(int(n_groups), 1)
    return min(n, MAX_GROUPS_X), -(-n // MAX_GROUPS_X), 1


def blocks(n: int, size: int = GROUP) -> int:
    return max(-(-int(n) // size), 1)


def words(n: int) -> Buffer:
    return Buffer(4 * max(int(n), 1), U32)


def scan(name: str, src: str, dst: str, n: int, counters: str, total_word: int = NO_TOTAL,
         scratch: str = "gb_scan_sums") -> list[Pass]:
    """Exclusive prefix sum of n uint words src -> dst; the total into counters[total_word]."""
    nb = blocks(n, SCAN_BLOCK)
    u = {"u_n": int(n), "u_blocks": nb, "u_total_word": int(total_word)}
    return [Pass(name, "build_scan.comp", reads=("src",),
                 writes={"dst": words(n), "sums": words(nb)}, groups=groups(nb),
                 defines={"SCAN_STEP": 0}, uniforms=u, sources={"src": src, "dst": dst, "sums": scratch}),
            Pass(name, "build_scan.comp", writes={"sums": words(nb), "counters": words(COUNTER_WORDS)},
                 groups=(1, 1, 1), defines={"SCAN_STEP": 1}, uniforms=u,
                 sources={"sums": scratch, "counters": counters}),
            Pass(name, "build_scan.comp", reads=("sums",), writes={"dst": words(n)},
                 groups=groups(nb), defines={"SCAN_STEP": 2}, uniforms=u,
                 sources={"sums": scratch, "dst": dst})]


def sort(name: str, keys: str, values: str, out_keys: str, out_values: str, capacity: int,
         key_bits: int, counters: str, count_word: int) -> list[Pass]:
    """Stable sort of the counters[count_word] pairs (keys, values) on the low key_bits of
    the keys into (out_keys, out_values), one pass per 8-bit digit; scratch buffers
    alternate with the outputs so that the last digit's pass writes the outputs."""
    digits = max(-(-int(key_bits) // DIGIT_BITS), 1)
    nb = blocks(capacity)
    hist = f"{name}_hist"
    out, scratch = (out_keys, out_values), (f"{name}_keys", f"{name}_values")
    dst_of = [out if (digits - 1 - d) % 2 == 0 else scratch for d in range(digits)]
    src = (keys, values)
    steps = []
    for d in range(digits):
        u = {"u_shift": d * DIGIT_BITS, "u_blocks": nb, "u_count_word": int(count_word)}
        steps.append(Pass(name, "build_sort.comp", reads=("counters", "src_keys"),
                          writes={"hist": words(nb * GROUP)}, groups=groups(nb),
                          defines={"SORT_STEP": 0}, uniforms=u,
                          sources={"counters": counters, "src_keys": src[0], "hist": hist}))
        steps += scan(name, hist, hist + "_scan", nb * GROUP, counters)
        dst = dst_of[d]
        steps.append(Pass(name, "build_sort.comp", reads=("counters", "src_keys", "src_values", "hist"),
                          writes={"dst_keys": words(capacity), "dst_values": words(capacity)},
                          groups=groups(nb), defines={"SORT_STEP": 1}, uniforms=u,
                          sources={"counters": counters, "src_keys": src[0], "src_values": src[1],
                                   "hist": hist + "_scan", "dst_keys": dst[0], "dst_values": dst[1]}))
        src = dst
    return steps
