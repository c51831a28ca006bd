// The binning's entries decoded (build_bin.comp BIN_STEP 1, build_zbin.comp's bits): entry e
// is the k-th cell of one light's box, the lights' first entries the scan of their counts.
// Needs, declared before it: light_first[], boxes[] (3 ivec2 a light: x, y, slice ranges),
// u_capacity (the per-light buffers' length), u_tiles, u_slices.

// The last light whose first entry is at or before e (the lights between own none).
uint entry_light(uint e) {
    uint lo = 0u, hi = u_capacity;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) >> 1;
        if (light_first[mid] <= e) lo = mid; else hi = mid;
    }
    return lo;
}

// The cell of a light's k-th entry: its box walked slice first, then x, then y (any walk
// would do: a light meets a cell once), cells tile-major (cpu_prep/grid.py).
uint entry_cell(uint light, uint k) {
    ivec2 x = boxes[3u * light], y = boxes[3u * light + 1u], sl = boxes[3u * light + 2u];
    uint ns = uint(sl.y - sl.x + 1), nx = uint(x.y - x.x + 1);
    uint s = uint(sl.x) + k % ns, tx = uint(x.x) + (k / ns) % nx, ty = uint(y.x) + k / (ns * nx);
    return (ty * uint(u_tiles.x) + tx) * uint(u_slices) + s;
}
