"""clustered's structures built on the GPU (--build gpu): the binning of the sorted lights
into the cells' index lists as compute passes of the frame graph, each buffer bit for bit
the CPU build's (cpu_prep.grid.bin_rects; tests/app/gpu_build/test_lists.py).  tree and
hybrid bin the same way before their trees (trees.py), zbin shares the boxes (zbins.py).

    (prepare.py: cull, sort, pack -> lights, gb_light_rect, light_depth)
    build_bin   boxes + counts[N] --scan--> light_first[N], entries -> counters[ENTRIES]
                (host step: entries read back, the entry buffers sized by it)
                expand (cell, light) per entry --sort by cell (stable)--> entries[E]
                ranges[cell] = (first, count) by binary search; longest -> counters[LONGEST]
                (host step: the longest list read back: the shading's dispatch windows)

Two readbacks, each a count the next buffers' sizes or the shading's windows need (4 bytes),
besides the visible count (prepare.py).
"""
from __future__ import annotations

import numpy as np

from cpu_prep import grid as gridmod, layouts, limits

from ..pipeline.passes import Build, Buffer, Pass
from . import steps
from .prepare import (COUNTER_FILES, COUNTERS, ENTRIES, LONGEST, PACK_OUTPUTS, check_items, counters,
                      host, readback_lights)


def bin_uniforms(grid: gridmod.Grid) -> dict:
    return {"u_tiles": (grid.tiles_x, grid.tiles_y), "u_slices": grid.slices}


def slice_table(grid: gridmod.Grid) -> np.ndarray:
    """The depths where listing 4 steps, NaN-padded to 2^k - 1 (grid.slice_from_table);
    one NaN for a grid of one slice (never read: its binary search takes no step)."""
    table = gridmod.slice_table(grid)
    return table if len(table) else np.full(1, np.nan)


def box_passes(b: Build, capacity: int) -> list[Pass]:
    """Each visible light's box of cells (gb_boxes: x, y and slice ranges; the grid's
    slice_table uploaded as gb_slice_table with the build) and its cell count, their scan (gb_light_first: each light's first entry; the entry count into
    counters[ENTRIES]).  capacity: the per-light buffers' length (the scene's lights)."""
    g, n = b.grid, capacity
    table = slice_table(g)
    boxes = Pass("build_bin", "build_bin.comp",
                 reads=("counters", "light_rect", "light_depth", "slice_table"),
                 writes={"boxes": steps.words(6 * n), "cell_counts": steps.words(n)},
                 groups=steps.groups(steps.blocks(n)), defines={"BIN_STEP": 0}, virtual=COUNTER_FILES,
                 uniforms=dict(bin_uniforms(g), u_capacity=n, u_tile=float(g.tile),
                               u_inv_tile=1.0 / float(g.tile),
                               u_depth_lo_scale=1.0 - limits.SLICE_DEPTH_REL_MARGIN,
                               u_depth_hi_scale=1.0 + limits.SLICE_DEPTH_REL_MARGIN,
                               u_table_size=len(table) if g.slices > 1 else 0),
                 sources={"counters": COUNTERS, "light_rect": "gb_light_rect",
                          "slice_table": "gb_slice_table", "boxes": "gb_boxes",
                          "cell_counts": "gb_cell_counts"})
    return [boxes] + steps.scan("build_bin", "gb_cell_counts", "gb_light_first", n, COUNTERS, ENTRIES)


def bin_lists(b: Build, then, ranges: str = "ranges") -> list:
    """The cells' index lists of b.grid (`entries`, and `ranges`: CELL_RANGE a cell), then
    `then(longest)`: the steps that follow once the longest list is known."""
    n = len(b.frame.lights)

    def sized(read):
        return {}, fill_cells(b, n, int(read[COUNTERS][ENTRIES]), then, ranges)
    return box_passes(b, n) + [host("build_bin_entries", (COUNTERS,), sized)]


def fill_cells(b: Build, capacity: int, entries: int, then, ranges: str) -> list:
    """The entries (cell, light) in light order, stable-sorted by cell; the ranges; then the
    host step that reads the longest list back and hands over to `then`."""
    g = b.grid
    check_items(b.frame, "the light index list", 4, entries, "list entries")
    expand = Pass("build_bin", "build_bin.comp", reads=("counters", "boxes", "light_first"),
                  writes={"entry_cells": steps.words(entries), "entry_lights": steps.words(entries)},
                  groups=steps.groups(steps.blocks(entries)), defines={"BIN_STEP": 1}, virtual=COUNTER_FILES,
                  uniforms=dict(bin_uniforms(g), u_capacity=capacity),
                  sources={"counters": COUNTERS, "boxes": "gb_boxes", "light_first": "gb_light_first",
                           "entry_cells": "gb_entry_cells", "entry_lights": "gb_entry_lights"})
    bounds = Pass("build_bin", "build_bin.comp", reads=("sorted_cells",),
                  writes={"counters": counters(),
                          "ranges": Buffer(g.cells * layouts.CELL_RANGE.itemsize, layouts.CELL_RANGE)},
                  groups=steps.groups(steps.blocks(g.cells)), defines={"BIN_STEP": 2}, virtual=COUNTER_FILES,
                  uniforms=dict(bin_uniforms(g), u_cells=g.cells),
                  sources={"counters": COUNTERS, "sorted_cells": "gb_sorted_cells", "ranges": ranges})
    b.stats["list_entries"] = entries
    b.longest_list = None                    # (known once the next host step has read it)
    cell_bits = max(int(g.cells - 1).bit_length(), 1)

    def longest(read):
        b.longest_list = int(read[COUNTERS][LONGEST])
        return {}, then(b.longest_list)
    return ([expand] + steps.sort("build_bin", "gb_entry_cells", "gb_entry_lights", "gb_sorted_cells",
                                  "entries", max(entries, 1), cell_bits, COUNTERS, ENTRIES)
            + [bounds, host("build_bin_longest", (COUNTERS,), longest)])


def readback_step(b: Build, names) -> "HostStep":
    """The packed lights (b.lights, b.buffers lights and light_depth) and the GPU-built
    buffers `names` read back into b.buffers, as the CPU build's arrays (figures only: the
    maps, the wave replay and the tests read the frame's structures from there); names:
    {buffer: (dtype, shape of one element, count)}."""
    def run(read):
        b.lights = readback_lights(read, len(b.lights))
        b.buffers["lights"] = b.lights.gpu
        b.buffers["light_depth"] = np.column_stack([b.lights.depth_lo, b.lights.depth_hi])
        for name, (dtype, shape, count) in names.items():
            b.buffers[name] = read[name].view(dtype).reshape((-1,) + tuple(shape))[:count].copy()
        return {}, []
    return host("build_readback", tuple(dict.fromkeys(PACK_OUTPUTS + tuple(names))), run, figures=True)


def list_readback(b: Build) -> dict:
    """The clustered lists' buffers for readback_step."""
    return {"ranges": (layouts.CELL_RANGE, (), b.grid.cells),
            "entries": (np.uint32, (), b.stats["list_entries"])}
