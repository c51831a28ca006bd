"""The replay's numba kernels: the lockstep walk of a program's segments (_replay_segments),
of a bit-array word loop (_replay_words) and of a tree traversal (_tree_visits), counting
per issued iteration its lanes, loads and distinct lines.

The kernels release the GIL (nogil): app.model.predict replays one wave width in a worker
thread while it builds and replays the next on the caller's.  numba's cache (cache=True)
re-checks this file alone; the cache folder is keyed by the source
of this whole package too (cpu_prep._cache_dir), so an edit of lights.py or kinds.py, whose
functions and constants are compiled in, recompiles."""
from __future__ import annotations

import numba
import numpy as np

from cpu_prep import zbin as zb

from .kinds import _COUNT_BITS, LIGHT, MASK_LIGHT, RUN, SET_BIT
from .lights import _misses_box, affects

# One issued iteration's distinct lines: a small open-addressing set, cleared by stamping.

_SET = 1024


@numba.njit(inline="always")
def _set_add(keys, stamps, stamp, key) -> int:
    """Add a line to this iteration's set; 1 if it was new."""
    h = (key * 0x9E3779B97F4A7C15) & (_SET - 1)
    while True:
        if stamps[h] != stamp:
            stamps[h] = stamp
            keys[h] = key
            return 1
        if keys[h] == key:
            return 0
        h = (h + 1) & (_SET - 1)


@numba.njit(inline="always")
def _lines(keys, stamps, stamp, seen, base, off, nbytes) -> int:
    """New distinct lines of a fetch of `nbytes` at byte `off` of the buffer whose first line
    is `base`; marks them in the frame's unique-line map."""
    new = 0
    for line in range(off // 64, (off + max(nbytes, 1) - 1) // 64 + 1):
        key = base + line
        seen[key] = True
        new += _set_add(keys, stamps, stamp, key)
    return new


@numba.njit(cache=True, nogil=True)
def _issue_lists(n, e_lane, e_list, e_first, e_count, e_scalar, list_start, list_lbuf, list_ebuf,
                 list_runs, flat_light, flat_slot, flat_eoff, P, spec, L, types, bound,
                 unbounded, keys, stamps, stamp, lo, hi, shapes, shaded, line_base, seen, loops,
                 types_acc, per_pixel, wx, wy, wz, wacc, wbits) -> int:
    """The inner light loops of n lanes run together: max(count) issued iterations, each
    the lanes' entry and light fetches and affects tests; returns the set's stamp.  The
    lanes' positions and hit counts live in the work arrays w* while the loops run."""
    longest, same = _longest(n, e_list, e_first, e_count, e_scalar)
    if longest == 0:
        return stamp
    _gather_lanes(n, e_lane, e_count, P, lo, hi, per_pixel, wx, wy, wz, wacc)
    if same:            # one list walked alike (brute's loop, a tile's list): per light, not lane
        stamp = _walk_shared_list(n, longest, e_lane, e_list[0], e_first[0], e_scalar[0],
                                  list_start, list_lbuf, list_ebuf, list_runs, flat_light,
                                  flat_slot, flat_eoff, spec, L, types, bound, unbounded, keys,
                                  stamps, stamp, lo, hi, shaded, line_base, seen, loops,
                                  types_acc, wx, wy, wz, wacc, wbits)
    else:
        stamp = _walk_lane_lists(n, longest, e_lane, e_list, e_first, e_count, e_scalar,
                                 list_start, list_lbuf, list_ebuf, flat_light, flat_slot,
                                 flat_eoff, spec, L, types, bound, unbounded, keys, stamps, stamp,
                                 lo, hi, shapes, shaded, line_base, seen, loops, types_acc,
                                 wx, wy, wz, wacc)
    for q in range(n):
        per_pixel[e_lane[q], 2] += wacc[q]
    return stamp


@numba.njit(inline="always")
def _longest(n, e_list, e_first, e_count, e_scalar):
    """The longest of the n lanes' lists, and whether every lane walks the same list (one
    cell, or wave-uniform)."""
    longest = 0
    same = n > 0
    for q in range(n):
        longest = max(longest, e_count[q])
        same &= e_scalar[q] == e_scalar[0] and e_list[q] == e_list[0] and \
            e_first[q] == e_first[0] and e_count[q] == e_count[0]
    return longest, same


@numba.njit(inline="always")
def _gather_lanes(n, e_lane, e_count, P, lo, hi, per_pixel, wx, wy, wz, wacc):
    """The lanes' positions into the work arrays, their hit counts zeroed, the box [lo, hi]
    of those with a light to walk, and the lights each evaluates added to its pixel."""
    lo[:] = np.inf
    hi[:] = -np.inf
    for q in range(n):
        px = e_lane[q]
        wx[q], wy[q], wz[q], wacc[q] = P[px, 0], P[px, 1], P[px, 2], 0
        per_pixel[px, 0] += e_count[q]
        if e_count[q] > 0:
            for k in range(3):
                lo[k] = min(lo[k], P[px, k])
                hi[k] = max(hi[k], P[px, k])


@numba.njit(cache=True, nogil=True)   # not inlined: numba inlines no call of over 30 arguments
def _walk_shared_list(n, longest, e_lane, lid, f0, scalar, list_start, list_lbuf, list_ebuf,
                      list_runs, flat_light, flat_slot, flat_eoff, spec, L, types, bound,
                      unbounded, keys, stamps, stamp, lo, hi, shaded, line_base, seen, loops,
                      types_acc, wx, wy, wz, wacc, wbits) -> int:
    """Every lane on list `lid` from `f0`: its lights' fetches counted once a light, each
    light tested against the lanes' box then each lane; a list walked in runs
    (LightList.runs) issues each run's set-bit loop.  Returns the stamp."""
    col = 3 if scalar else 2                        # its loads: scalar or vector
    runs = list_runs[lid]
    row = MASK_LIGHT if runs else LIGHT      # evaluate_all_lights' mask loop, or a list's
    loops[row, 0] += longest
    loops[row, 1] += longest * n
    for t in range(longest):
        p = list_start[lid] + f0 + t
        li = flat_light[p]
        lines = 0
        if flat_eoff[p] >= 0:
            loops[row, col] += 1
            seen[line_base[list_ebuf[lid]] + flat_eoff[p] // 64] = True
            lines += 1
        off = flat_slot[p] * 96
        for line in range(off // 64, (off + 95) // 64 + 1):
            seen[line_base[list_lbuf[lid]] + line] = True
            lines += 1
        loops[row, col] += 1
        loops[row, col + 2] += lines
        types_acc[0, types[li]] += 1
        if runs and t % RUN == 0:
            wbits[:n] = 0
        if unbounded or not _misses_box(li, L, bound, lo, hi):
            hit, sp = False, False
            for q in range(n):
                if affects(wx[q], wy[q], wz[q], li, L, types, unbounded):
                    if runs:
                        wbits[q] |= 1 << (t % RUN)
                    else:
                        wacc[q] += 1
                        hit = True
                        sp |= spec[e_lane[q]]
            if not runs:
                types_acc[1, types[li]] += hit
                types_acc[2, 0] += sp
        if runs and (t % RUN == RUN - 1 or t == longest - 1):
            stamp = _issue_set_bits(n, e_lane, wbits, list_start[lid] + f0 + t - t % RUN,
                                    line_base[list_lbuf[lid]], flat_light, flat_slot, spec,
                                    types, keys, stamps, stamp, seen, shaded, loops,
                                    types_acc, wacc)
    return stamp


@numba.njit(cache=True, nogil=True)   # not inlined: numba inlines no call of over 30 arguments
def _walk_lane_lists(n, longest, e_lane, e_list, e_first, e_count, e_scalar, list_start,
                     list_lbuf, list_ebuf, flat_light, flat_slot, flat_eoff, spec, L, types,
                     bound, unbounded, keys, stamps, stamp, lo, hi, shapes, shaded, line_base,
                     seen, loops, types_acc, wx, wy, wz, wacc) -> int:
    """Each lane on its own list: per issued iteration the k-th entry of every lane with one
    left, fetched once per run of lanes at one entry.  Returns the stamp."""
    for t in range(longest):
        stamp += 1
        active, lines, entry_loads, scalar = 0, 0, False, False
        shapes[:] = False
        shaded[:] = False
        any_spec = False
        last, last_p, miss = -1, -1, False
        for q in range(n):
            if e_count[q] <= t:
                continue
            lid = e_list[q]
            p = list_start[lid] + e_first[q] + t
            li = flat_light[p]
            active += 1
            scalar = e_scalar[q]
            if p != last_p:                  # lanes of one cell fetch the same entry
                last_p = p
                if flat_eoff[p] >= 0:
                    entry_loads = True
                    lines += _lines(keys, stamps, stamp, seen, line_base[list_ebuf[lid]],
                                    flat_eoff[p], 4)
                lines += _lines(keys, stamps, stamp, seen, line_base[list_lbuf[lid]],
                                flat_slot[p] * 96, 96)
            last, miss, hit = _evaluate(li, last, miss, wx[q], wy[q], wz[q], L, types, bound,
                                        lo, hi, unbounded, shapes, shaded)
            if hit:
                wacc[q] += 1
                any_spec |= spec[e_lane[q]]
        _issue_lights(active, 2 if entry_loads else 1, lines, scalar, shapes, shaded,
                      any_spec, loops, types_acc)
    return stamp


@numba.njit(inline="always")
def _issue_set_bits(n, e_lane, wbits, p0, lbase, flat_light, flat_slot, spec, types, keys,
                    stamps, stamp, seen, shaded, loops, types_acc, wacc) -> int:
    """evaluate_all_lights' set-bit loop over one run (glsl/pixel.glsl): per issued
    iteration every lane with bits left shades its lowest one (a vector load of its light,
    the shapes the lanes are at); as many iterations as the busiest lane has bits (none for
    an empty run: a GPU tests the loop before its body).  Returns the stamp."""
    while True:
        stamp += 1
        active, lines, any_spec = 0, 0, False
        shaded[:] = False
        for q in range(n):
            m = wbits[q]
            if m == 0:
                continue
            bit = 0
            while not (m >> bit) & 1:
                bit += 1
            wbits[q] = m & (m - 1)
            p = p0 + bit
            li = flat_light[p]
            active += 1
            lines += _lines(keys, stamps, stamp, seen, lbase, flat_slot[p] * 96, 96)
            shaded[types[li]] = True
            any_spec |= spec[e_lane[q]]
            wacc[q] += 1
        if active == 0:
            return stamp
        loops[SET_BIT, 0] += 1
        loops[SET_BIT, 1] += active
        _count_loads(SET_BIT, 1, lines, False, loops)
        for ty in range(types_acc.shape[1]):
            types_acc[1, ty] += shaded[ty]
        types_acc[2, 0] += any_spec


@numba.njit(inline="always")
def _count_loads(kind, loads, lines, scalar, loops):
    """An issued iteration's loads and cache lines, on the scalar or the vector unit."""
    if scalar:
        loops[kind, 3] += loads
        loops[kind, 5] += lines
    else:
        loops[kind, 2] += loads
        loops[kind, 4] += lines


@numba.njit(inline="always")
def _issue_head(kind, heads, lines, scalar, lds, loops):
    """One issued iteration of a head kind over `heads` lanes."""
    loops[kind, 0] += 1
    loops[kind, 1] += heads
    if lds:
        loops[kind, 6] += heads
    else:
        _count_loads(kind, 1, lines, scalar, loops)


@numba.njit(inline="always")
def _wave_scratch():
    """A replay's scratch: the cache-line set (_lines: keys, stamps), a wave's box of
    shading positions (lo, hi) and the light shapes an iteration met and shaded."""
    return (np.zeros(_SET, np.int64), np.zeros(_SET, np.int64), np.empty(3, np.float32),
            np.empty(3, np.float32), np.zeros(8, np.bool_), np.zeros(8, np.bool_))


@numba.njit(inline="always")
def _positions(n):
    """x, y, z of n lanes' positions (float32, as the shader's)."""
    xyz = np.zeros((3, n), np.float32)
    return xyz[0], xyz[1], xyz[2]


@numba.njit(inline="always")
def _evaluate(li, last, miss, x, y, z, L, types, bound, lo, hi, unbounded, shapes, shaded):
    """A lane's evaluate_light of light li at (x, y, z): the wave's box test once per light
    in a row (lanes on one light share it; `last`, `miss`: the previous one's), then the
    lane's own test.  Returns (li, its miss, whether it affects the lane)."""
    if li != last:
        shapes[types[li]] = True
        miss = not unbounded and _misses_box(li, L, bound, lo, hi)
    hit = not miss and affects(x, y, z, li, L, types, unbounded)
    if hit:
        shaded[types[li]] = True
    return li, miss, hit


@numba.njit(inline="always")
def _issue_lights(active, loads, lines, scalar, shapes, shaded, any_spec, loops, types_acc):
    """One issued iteration of a light loop over `active` lanes: its loads (the entry and
    the light, or the light) and lines, the shapes it met and those it shaded."""
    loops[5, 0] += 1
    loops[5, 1] += active
    _count_loads(5, loads, lines, scalar, loops)
    for ty in range(types_acc.shape[1]):
        types_acc[0, ty] += shapes[ty]
        types_acc[1, ty] += shaded[ty]
    types_acc[2, 0] += any_spec


@numba.njit(cache=True, nogil=True)
def _replay_segments(wave, lane, step, hoff, first, count, call, calls,
                     list_start, list_lbuf, list_ebuf, list_runs, flat_light, flat_slot,
                     flat_eoff, nmin, nmax, nfirst, nbits, depth,
                     P, spec, L, types, bound, unbounded,
                     line_base, seen, loops, types_acc, per_pixel):
    """Groups of segments of one (wave, branch, step): their heads as one issued iteration,
    then their lists together; a group's tree segments walk their trees in lockstep, a
    node visit per lane a step, each visit's hit leaves' lists together."""
    n = len(wave)
    biggest, i = 0, 0
    while i < n:                                         # the largest group, for buffers
        j = _group_end(wave, step, call, calls, i, n)
        biggest = max(biggest, j - i)
        i = j
    keys, stamps, lo, hi, shapes, shaded = _wave_scratch()
    stamp = 0
    # per segment of a group: its list entry (lane, list, first, count), tree walk (segment,
    # cursor) and lights affecting it; the lane's position
    ints = np.zeros((8, biggest), np.int64)
    e_lane, e_list, e_first, e_count, t_seg, t_cur, wacc, wbits = \
        ints[0], ints[1], ints[2], ints[3], ints[4], ints[5], ints[6], ints[7]
    e_scalar = np.zeros(biggest, np.bool_)
    wx, wy, wz = _positions(biggest)
    i = 0
    while i < n:
        j = _group_end(wave, step, call, calls, i, n)
        # heads of the plain segments: one issued iteration
        stamp += 1
        kind, heads, lines, scalar, lds, m, trees = _plain_heads(
            i, j, lane, hoff, first, count, call, calls, keys, stamps, stamp, seen, line_base,
            per_pixel, e_lane, e_list, e_first, e_count, e_scalar, t_seg, t_cur)
        if kind >= 0:
            _issue_head(kind, heads, lines, scalar, lds, loops)
        stamp = _issue_lists(m, e_lane, e_list, e_first, e_count, e_scalar, list_start,
                             list_lbuf, list_ebuf, list_runs, flat_light, flat_slot, flat_eoff, P,
                             spec, L, types, bound, unbounded, keys, stamps,
                             stamp, lo, hi, shapes, shaded, line_base, seen, loops, types_acc,
                             per_pixel, wx, wy, wz, wacc, wbits)
        # the group's traversals in lockstep
        while trees > 0:
            stamp += 1
            kind, heads, lines, lds, m = _tree_visit(
                trees, t_seg, t_cur, lane, first, count, call, calls, depth, nmin, nmax, nfirst,
                nbits, keys, stamps, stamp, seen, line_base, per_pixel, e_lane, e_list, e_first,
                e_count, e_scalar)
            if heads == 0:
                break
            _issue_head(kind, heads, lines, False, lds, loops)
            stamp = _issue_lists(m, e_lane, e_list, e_first, e_count, e_scalar, list_start,
                                 list_lbuf, list_ebuf, list_runs, flat_light, flat_slot, flat_eoff,
                                 P, spec, L, types, bound, unbounded, keys, stamps,
                                 stamp, lo, hi, shapes, shaded, line_base, seen, loops,
                                 types_acc, per_pixel, wx, wy, wz, wacc, wbits)
        i = j


@numba.njit(inline="always")
def _group_end(wave, step, call, calls, i, n):
    """The end of the group of segments from i: those of one (wave, branch, step)."""
    j = i
    while j < n and wave[j] == wave[i] and calls[call[j], 0] == calls[call[i], 0] \
            and step[j] == step[i]:
        j += 1
    return j


@numba.njit(inline="always")
def _plain_heads(i, j, lane, hoff, first, count, call, calls, keys, stamps, stamp, seen,
                 line_base, per_pixel, e_lane, e_list, e_first, e_count, e_scalar, t_seg, t_cur):
    """A group's plain segments: their heads (kind, lanes, new lines, scalar, from shared
    memory) and their lists' entries (m of them); its tree segments set aside (trees)."""
    kind, heads, lines, scalar, lds = -1, 0, 0, False, False
    # m is _issue_lists' n: typed, not the literal 0, or numba compiles _issue_lists
    # twice, once for n = Literal[int](0) (a call's literal argument is its own
    # specialization: ~6 s more of a cold compile, the same code)
    m, trees = np.int64(0), 0
    for s in range(i, j):
        c = call[s]
        if calls[c, 7]:                              # a tree: walked below
            t_seg[trees] = s
            t_cur[trees] = 0
            trees += 1
            continue
        if calls[c, 1] >= 0:
            kind = calls[c, 1]
            heads += 1
            scalar = calls[c, 4] != 0
            if kind == 1 or kind == 2:               # a node visit (global or shared)
                per_pixel[lane[s], 1] += 1
            if calls[c, 2] == -2:
                lds = True
            else:
                lines += _lines(keys, stamps, stamp, seen, line_base[calls[c, 2]], hoff[s], calls[c, 3])
        if calls[c, 5] >= 0 and count[s] > 0:
            e_lane[m], e_list[m], e_first[m] = lane[s], calls[c, 5], first[s]
            e_count[m], e_scalar[m] = count[s], calls[c, 6] != 0
            m += 1
    return kind, heads, lines, scalar, lds, m, trees


@numba.njit(inline="always")
def _tree_visit(trees, t_seg, t_cur, lane, first, count, call, calls, depth, nmin, nmax, nfirst,
                nbits, keys, stamps, stamp, seen, line_base, per_pixel, e_lane, e_list, e_first,
                e_count, e_scalar):
    """One lockstep step of a group's traversals: each unfinished lane's next node (kind,
    lanes, new lines, from shared memory), the hit leaves' lists as m entries."""
    cmask = (1 << _COUNT_BITS) - 1
    heads, lines, m = 0, 0, np.int64(0)              # m typed: see _plain_heads
    kind, lds = -1, False
    for q in range(trees):
        s = t_seg[q]
        c = call[s]
        if t_cur[q] >= count[s]:
            continue
        node = first[s] + t_cur[q]
        heads += 1
        kind = calls[c, 1]
        per_pixel[lane[s], 1] += 1
        if calls[c, 2] == -2:
            lds = True
        else:
            lines += _lines(keys, stamps, stamp, seen, line_base[calls[c, 2]], node * 16, 16)
        d = depth[lane[s]]
        bits = nbits[node]
        if d >= nmin[node] and d <= nmax[node]:
            if bits & 1:
                e_lane[m], e_list[m], e_first[m] = lane[s], calls[c, 5], nfirst[node]
                e_count[m], e_scalar[m] = (bits >> 1) & cmask, False
                m += 1
            t_cur[q] += 1
        else:
            t_cur[q] += bits >> (1 + _COUNT_BITS)
    return kind, heads, lines, lds, m


@numba.njit(inline="always")
def _zbin_mask(lo, hi, w, printed):
    """A lane's z-bin mask of word w (shade_zbin.comp zbin_word_mask)."""
    return np.uint32(zb.zbin_word_mask(lo, hi, w) if printed else zb.range_mask(lo, hi, w))


@numba.njit(cache=True, nogil=True)
def _replay_words(order, wave, shading, live, address, zlo, zhi, bits, words, masked, scalarized,
                  printed, bits_buf, P, spec, L, types, bound, unbounded,
                  line_base, seen, loops, types_acc, per_pixel):
    """shade_zbin.comp / raster_shade_cluster.comp: per wave the word range (masked: from
    the lanes' z-bin min / max), per word the lanes' words (a vector load each), then the
    per-lane bit loop (max set bits) or the scalar loop over the wave's OR of them."""
    n = len(order)
    keys, stamps, lo, hi, shapes, shaded = _wave_scratch()
    stamp = 0
    own = np.zeros(64, np.uint32)
    wx, wy, wz = _positions(64)
    w_ev = np.zeros(64, np.int64)
    w_hit = np.zeros(64, np.int64)
    i = 0
    while i < n:
        j = i
        while j < n and wave[j] == wave[i]:
            j += 1
        w0, w1 = _word_range(i, j, shading, zlo, zhi, masked, words)
        busy, alive = _gather_wave(i, j, order, shading, live, P, wx, wy, wz, w_ev, w_hit, lo, hi)
        if busy == 0:
            if scalarized and w1 > w0 and alive:  # the native loop runs its words unguarded
                loops[3, 0] += w1 - w0
            i = j
            continue
        for wd in range(w0, w1):
            # the word: a vector load per shading lane (lane_word)
            stamp += 1
            lines = _load_word(i, j, wd, shading, address, zlo, zhi, bits, masked, scalarized,
                               printed, keys, stamps, stamp, seen, line_base[bits_buf], own)
            loops[3, 0] += 1
            loops[3, 1] += busy
            loops[3, 2] += 1
            loops[3, 4] += lines
            stamp = _word_lights(i, j, wd, order, own, spec, L, types, bound, lo, hi, unbounded,
                                 shapes, shaded, keys, stamps, stamp, seen, line_base[0],
                                 scalarized, loops, types_acc, wx, wy, wz, w_ev, w_hit)
        for s in range(i, j):               # the wave's lanes' sums, once
            per_pixel[order[s], 0] += w_ev[s - i]
            per_pixel[order[s], 2] += w_hit[s - i]
        i = j


@numba.njit(inline="always")
def _word_range(i, j, shading, zlo, zhi, masked, words):
    """The words [w0, w1) the wave of lanes i..j walks: all, or (masked) those of its
    shading lanes' z-bin ids."""
    w0, w1 = 0, words
    if masked:
        mn, mx = 0x7FFFFFFF, 0                       # an empty wave's min
        for s in range(i, j):
            if shading[s]:
                mn = min(mn, zlo[s])
                mx = max(mx, zhi[s])
        w0, w1 = max(w0, mn // 32), min(w1, mx // 32 + 1)
    return w0, w1


@numba.njit(inline="always")
def _gather_wave(i, j, order, shading, live, P, wx, wy, wz, w_ev, w_hit, lo, hi):
    """The wave's lanes' positions into the work arrays, their sums zeroed, the box [lo, hi]
    of its shading lanes; returns (shading lanes, whether any lane is live)."""
    busy, alive = 0, False
    for s in range(i, j):
        q = s - i
        alive |= live[s]
        wx[q], wy[q], wz[q] = P[order[s], 0], P[order[s], 1], P[order[s], 2]
        w_ev[q], w_hit[q] = 0, 0
        busy += shading[s]
        if shading[s]:
            for k in range(3):
                lo[k] = P[order[s], k] if busy == 1 else min(lo[k], P[order[s], k])
                hi[k] = P[order[s], k] if busy == 1 else max(hi[k], P[order[s], k])
    return busy, alive


@numba.njit(inline="always")
def _load_word(i, j, wd, shading, address, zlo, zhi, bits, masked, scalarized, printed, keys,
               stamps, stamp, seen, base, own):
    """Word wd of each shading lane (masked by its z-bin range) into own, or (scalarized)
    the wave's OR of them into every shading lane's; returns the loads' new lines."""
    lines = 0
    merged = np.uint32(0)
    for s in range(i, j):
        m = np.uint32(0)
        if shading[s]:
            a = address[s] + wd
            lines += _lines(keys, stamps, stamp, seen, base, a * 4, 4)
            m = bits[a]
            if masked:
                m &= _zbin_mask(zlo[s], zhi[s], wd, printed)
        own[s - i] = m
        merged |= m
    if scalarized:
        for s in range(i, j):
            own[s - i] = merged if shading[s] else np.uint32(0)
    return lines


@numba.njit(inline="always")
def _word_lights(i, j, wd, order, own, spec, L, types, bound, lo, hi, unbounded, shapes, shaded,
                 keys, stamps, stamp, seen, lbase, scalarized, loops, types_acc, wx, wy, wz,
                 w_ev, w_hit) -> int:
    """The light loop of word wd, per lane its own bits in order (or, scalarized, every lane
    the merged bits): per issued iteration every lane with bits left evaluates its lowest
    one.  Returns the stamp."""
    while True:
        stamp += 1
        active, lines, scalar = 0, 0, scalarized
        shapes[:] = False
        shaded[:] = False
        any_spec = False
        last, miss = -1, False
        for s in range(i, j):
            m = own[s - i]
            if m == 0:
                continue
            bit = 0
            while not (m >> np.uint32(bit)) & np.uint32(1):
                bit += 1
            own[s - i] = m & (m - np.uint32(1))
            li = wd * 32 + bit
            q = s - i
            active += 1
            w_ev[q] += 1
            if li != last:               # lanes of one tile fetch the same light
                lines += _lines(keys, stamps, stamp, seen, lbase, li * 96, 96)
            last, miss, hit = _evaluate(li, last, miss, wx[q], wy[q], wz[q], L, types,
                                        bound, lo, hi, unbounded, shapes, shaded)
            if hit:
                w_hit[q] += 1
                any_spec |= spec[order[s]]
        if active == 0:
            return stamp
        _issue_lights(active, 1, lines, scalar, shapes, shaded, any_spec, loops, types_acc)


@numba.njit(cache=True, nogil=True)
def _tree_visits(depth, base, count, nmin, nmax, nfirst, nbits, count_bits, out):
    """Tree paper listing 3 for each lane (glsl/tree.glsl traverse_tree): its node visits in
    order.  out=None counts them; else fills out[k] = (lane, visit, node, leaf first, leaf
    count: 0 unless the visit hit a leaf)."""
    k = 0
    cmask = (1 << count_bits) - 1
    for lane in range(len(depth)):
        i = 0
        visit = 0
        d = depth[lane]
        while i < count[lane]:
            node = base[lane] + i
            bits = nbits[node]
            hit = d >= nmin[node] and d <= nmax[node]
            first, n = 0, 0
            if hit:
                if bits & 1:
                    first = nfirst[node]
                    n = (bits >> 1) & cmask
                i += 1
            else:
                i += bits >> (1 + count_bits)
            if out is not None:
                out[k, 0] = lane
                out[k, 1] = visit
                out[k, 2] = node
                out[k, 3] = first
                out[k, 4] = n
            k += 1
            visit += 1
    return k


@numba.njit(cache=True, nogil=True)
def _gather_rows(order, columns):
    """columns[:, order] in one pass (Program.segments: the segments' columns in replay
    order; numpy's fancy indexing, a column at a time, took twice as long)."""
    rows, n = columns.shape[0], len(order)
    out = np.empty((rows, n), columns.dtype)
    for i in range(n):
        j = order[i]
        for r in range(rows):
            out[r, i] = columns[r, j]
    return out
