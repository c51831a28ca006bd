"""zbin's structures built on the GPU (--build gpu): Drobot's Z-bin LUT and the flat tile bit
arrays as compute passes (app/gpu_build/build_zbin.comp), each bit for bit cpu_prep/zbin.py's
(tests/app/gpu_build/test_zbins.py).

    (prepare.py: cull, sort, pack -> lights, gb_light_rect, light_depth; the visible count
     read back with the sorted ids: the bits' tile, words and the LUT's width follow from it)
    build_zbin  each light's bin range onto a segment tree of the bins (atomic min / max of
                its id on O(log bins) nodes) -> each bin's min and max id (leaf to root)
                -> zbins[bins] (min | max << 16), or (bins, 2) past 65,536 visible lights
    build_bin   each light's tile box (build_bin.comp on the one-slice grid) and count
                --scan--> light_first, entries -> counters[ENTRIES] (read back: the
                dispatch) -> each entry's bit atomically OR-ed into tile_bits

The CPU paints each bin with the first and the last light whose range holds it (union-find,
O(lights + bins)); the segment tree finds the same two ids with no order between the lights,
which a GPU does not have: O(log bins) atomics a light, O(log bins) reads a bin.
"""
from __future__ import annotations

import numpy as np

from cpu_prep import zbin as zb
from cpu_prep.limits import LimitError

from ..pipeline.passes import Build, Buffer, Pass
from . import steps
from .lists import bin_uniforms
from .prepare import COUNTER_FILES, COUNTERS


def tree_leaves(bins: int) -> int:
    """The segment tree's leaves: the bins rounded up to a power of two."""
    return 1 << max(int(bins) - 1, 0).bit_length()


def lut_passes(b: Build, bins: int, capacity: int) -> list[Pass]:
    """The Z-bin LUT of the frame's sorted lights into `zbins` (its scale into
    b.bin_scale, as bit_arrays.attach_zbins)."""
    n = len(b.lights)
    wide = zb.is_wide(n)
    if wide and n > zb.ZBIN_WIDE_EMPTY_MIN:
        raise LimitError(f"zbin: {n} lights exceed the 31-bit ids of the wide LUT")
    scale = zb.bin_scale(bins, b.frame.max_depth)
    b.bin_scale = float(scale)
    size = tree_leaves(bins)
    defines = {"ZBIN_WIDE": int(wide),
               "ZBIN_EMPTY_MIN": zb.ZBIN_WIDE_EMPTY_MIN if wide else zb.ZBIN_NARROW_EMPTY}
    nodes = {"zmin": Buffer(8 * size, cleared=True), "zmax": Buffer(8 * size, cleared=True)}
    mark = Pass("build_zbin", "build_zbin.comp", reads=("counters", "light_depth"), writes=nodes,
                groups=steps.groups(steps.blocks(capacity)), defines=dict(defines, ZBIN_STEP=0),
                uniforms={"u_capacity": capacity, "u_size": size, "u_scale": float(scale),
                          "u_lo_scale": 1.0 - zb.ZBIN_DEPTH_REL_MARGIN,
                          "u_hi_scale": 1.0 + zb.ZBIN_DEPTH_REL_MARGIN, "u_bins": bins},
                sources={"counters": COUNTERS, "zmin": "gb_zmin", "zmax": "gb_zmax"},
                virtual=COUNTER_FILES)
    lut = Pass("build_zbin", "build_zbin.comp", reads=("zmin", "zmax"),
               writes={"zbins": Buffer(4 * bins * (2 if wide else 1))},
               groups=steps.groups(steps.blocks(bins)), defines=dict(defines, ZBIN_STEP=1),
               uniforms={"u_size": size, "u_bins": bins},
               sources={"zmin": "gb_zmin", "zmax": "gb_zmax"}, virtual=COUNTER_FILES)
    return [mark, lut]


def lut_readback(b: Build, bins: int) -> dict:
    """The LUT for lists.readback_step, in cpu_prep.zbin.pack_lut's shape."""
    return {"zbins": (np.uint32, (2,) if zb.is_wide(len(b.lights)) else (), bins)}


def bits_pass(b: Build, capacity: int, entries: int) -> Pass:
    """Each (tile, light) entry's bit into tile_bits (cleared first), from gb_boxes and
    gb_light_first (lists.box_passes on b.grid, one slice)."""
    g, words = b.grid, zb.words_for(len(b.lights))
    return Pass("build_bin", "build_zbin.comp", reads=("counters", "boxes", "light_first"),
                writes={"tile_bits": Buffer(4 * g.tiles_x * g.tiles_y * words, cleared=True)},
                groups=steps.groups(steps.blocks(entries)), defines={"ZBIN_STEP": 2},
                uniforms=dict(bin_uniforms(g), u_capacity=capacity, u_words=words),
                sources={"counters": COUNTERS, "boxes": "gb_boxes", "light_first": "gb_light_first"},
                virtual=COUNTER_FILES)


def bits_readback(b: Build) -> dict:
    g = b.grid
    return {"tile_bits": (np.uint32, (), g.tiles_x * g.tiles_y * zb.words_for(len(b.lights)))}
