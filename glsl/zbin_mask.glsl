// The word masks of the flat bit arrays (bit N = light N of the depth-sorted list): the
// slides' BitFieldMask, the exact mask of a light id range, the dispatch window's mask.
// shade_zbin.comp's loop and the cluster rasterizer's (raster_shade_cluster.comp); after
// common.glsl (u_window).  cpu_prep.zbin holds the CPU twins (bit_field_mask, range_mask).

// GCN's v_bfm_b32, the slides' BitFieldMask: ((1 << width) - 1) << offset, 5-bit operands.
uint BitFieldMask(uint width, uint offset) {
    return ((1u << (width & 31u)) - 1u) << (offset & 31u);
}

// Bits of word `w` that hold lights lo..hi (inclusive; none when lo > hi), built with
// BitFieldMask and the listing's manual 32-wide wrap.  Ids below 2^31 (cpu_prep.zbin).
uint range_mask(uint lo, uint hi, uint w) {
    int base = int(w * 32u);
    uint a = uint(clamp(int(lo) - base, 0, 32));
    uint b = uint(clamp(int(hi) - base, -1, 31) + 1);
    uint width = b > a ? b - a : 0u;
    return width == 32u ? 0xFFFFFFFFu : BitFieldMask(width, a);
}

// Bits of word `w` whose light lies in this dispatch window [u_window.x, u_window.y).
uint window_mask(uint w) {
    if (u_window.y == 0u || u_window.x >= u_window.y) return 0u;
    return range_mask(min(u_window.x, 0x7FFFFFFFu), min(u_window.y - 1u, 0x7FFFFFFFu), w);
}
