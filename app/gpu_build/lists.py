"""clustered's structures built on the GPU (--build gpu): the frame's cull, depth sort and
binning as compute passes of the frame graph, each buffer bit for bit the CPU build's
(cpu_prep.frame.prepare_lights + grid.bin_rects; tests/app/gpu_build/test_lists.py).

    scene lights (LIGHT_DTYPE words, uploaded)
      build_cull  flags[N], cull_keys[N]  --scan-->  places[N], visible -> counters[0]
                  compact: sort_in (key, scene id) of the visible lights, in scene order
      build_sort  4 digits of 8 bits (steps.sort): sorted_ids, in depth order, ties in scene order
      build_pack  (host step) the light records, rectangles and depth ranges (see below)
      build_bin   boxes + counts[N] --scan--> light_first[N], entries -> counters[1]
                  (host step: entries read back, the entry buffers sized by it)
                  expand (cell, light) per entry --sort by cell (stable)--> entries[E]
                  ranges[cell] = (first, count) by binary search; longest -> counters[2]
                  (host step: the longest list read back: the shading's dispatch windows)

Three readbacks, each a count the next buffers' sizes or the shading's windows need (4
bytes), and one of the sorted ids for the pack.  The pack (GPU_LIGHT rows, each shape's
screen rectangle and depth range: cpu_prep.bounds) still runs on the CPU, on the GPU's
order: its bounds mix float32 and float64 operations as numba types them, which a port
must follow op by op to stay bit for bit; it is the next step (docs/cpu_stage.md).
"""
from __future__ import annotations

import numpy as np

from cpu_prep import grid as gridmod, layouts, lights as lightsmod, limits
from cpu_prep.bounds import F32_EPS, HALF_SQRT2
from scenes.model import LIGHT_DTYPE

from ..pipeline.passes import Build, Buffer, FrameInput, HostStep, Pass
from . import steps

COUNTERS = "gb_counters"
# Build.data key of a GPU build's steps, run by the renderer in place of technique.passes()
BUILD_STEPS = "build_steps"
VISIBLE, ENTRIES, LONGEST, SCRATCH = 0, 1, 2, 3          # counter words
CULL_KEY_BITS = 32
# the scene record's fields as 4-byte words (LIGHT_DTYPE: type is its first byte)
_SL = {f"SL_{n.upper()}": LIGHT_DTYPE.fields[n][1] // 4
       for n in ("type", "position", "radius", "direction", "cos_outer", "length", "extent")}
SCENE_DEFINES = dict(_SL, SL_WORDS=LIGHT_DTYPE.itemsize // 4)
assert LIGHT_DTYPE.itemsize % 4 == 0 and LIGHT_DTYPE.fields["type"][1] == 0
COUNTER_DEFINES = {"COUNTER_VISIBLE": VISIBLE, "COUNTER_ENTRIES": ENTRIES, "COUNTER_LONGEST": LONGEST}


def scene_words(lights: np.ndarray) -> np.ndarray:
    """The scene's light records as the uint32 words the cull reads."""
    return np.ascontiguousarray(lights).view(np.uint32)


def cull_uniforms(frame: FrameInput) -> dict:
    """The cull's camera and margins, as cpu_prep.lights.cull and _cull compute them."""
    cam = frame.camera
    m = np.asarray(cam.view_from_world, np.float64)
    tx = cam.tan_half_x * (1.0 + 2.0 * limits.PIXEL_MARGIN / cam.width)      # lights.cull
    ty = cam.tan_half_y * (1.0 + 2.0 * limits.PIXEL_MARGIN / cam.height)
    return {"u_view_x": tuple(m[0]), "u_view_y": tuple(m[1]), "u_view_z": tuple(m[2]),
            "u_near_lo": cam.near * (1 - limits.RADIUS_REL_MARGIN),
            "u_far_hi": cam.far * (1 + limits.RADIUS_REL_MARGIN),
            "u_tan_x": tx, "u_tan_y": ty,
            "u_norm_x": float(np.sqrt(1.0 + tx * tx)), "u_norm_y": float(np.sqrt(1.0 + ty * ty)),
            "u_grow_scale": 1.0 + limits.RADIUS_REL_MARGIN, "u_grow_eps": 4.0 * F32_EPS,
            "u_half_sqrt2": HALF_SQRT2, "u_n": len(frame.lights)}


def cull_and_sort(frame: FrameInput) -> list[Pass]:
    """The cull, its compaction and the depth sort: gb_sorted_ids[counters[VISIBLE]]."""
    n = len(frame.lights)
    nb = steps.groups(steps.blocks(n))
    u = cull_uniforms(frame)
    cull = Pass("build_cull", "build_cull.comp", reads=("scene_lights",),
                writes={"flags": steps.words(n), "cull_keys": steps.words(n)}, groups=nb,
                defines=dict(SCENE_DEFINES, CULL_STEP=0), uniforms=u,
                sources={"flags": "gb_flags", "cull_keys": "gb_cull_keys"})
    compact = Pass("build_cull", "build_cull.comp", reads=("flags", "cull_keys", "places"),
                   writes={"keys": steps.words(n), "values": steps.words(n)}, groups=nb,
                   defines=dict(SCENE_DEFINES, CULL_STEP=1), uniforms={"u_n": n},
                   sources={"flags": "gb_flags", "cull_keys": "gb_cull_keys", "places": "gb_places",
                            "keys": "gb_sort_in_keys", "values": "gb_sort_in_ids"})
    clear = Pass("build_cull", "build_scan.comp", writes={"sums": steps.words(1),
                                                          "counters": Buffer(16, steps.U32, cleared=True)},
                 groups=(1, 1, 1), defines={"SCAN_STEP": 1},
                 uniforms={"u_n": 0, "u_blocks": 0, "u_total_word": SCRATCH},
                 sources={"sums": "gb_scan_sums", "counters": COUNTERS})
    return ([clear, cull] + steps.scan("build_cull", "gb_flags", "gb_places", n, COUNTERS, VISIBLE)
            + [compact]
            + steps.sort("build_sort", "gb_sort_in_keys", "gb_sort_in_ids", "gb_sorted_keys",
                         "gb_sorted_ids", n, CULL_KEY_BITS, COUNTERS, VISIBLE))


def pack_step(b: Build, then) -> HostStep:
    """The CPU pack on the GPU's depth order: the light records (uploaded as `lights`), the
    rectangles and depth ranges the binning reads; b.lights becomes the frame's lights.
    `then(b)`: the steps after it."""
    def run(read):
        visible = int(read[COUNTERS][VISIBLE])
        ids = read["gb_sorted_ids"][:visible].astype(np.uint64)
        pl = lightsmod.pack(b.frame.lights, b.frame.camera, ids)
        b.lights = pl
        b.buffers["lights"] = pl.gpu
        b.stats["visible_lights"] = visible
        uploads = {"lights": pl.gpu, "gb_light_rect": pl.rect,
                   "gb_light_depth": np.column_stack([pl.depth_lo, pl.depth_hi])}
        return uploads, then(b)
    return HostStep("build_pack", (COUNTERS, "gb_sorted_ids"), run)


def bin_uniforms(grid: gridmod.Grid) -> dict:
    return {"u_tiles": (grid.tiles_x, grid.tiles_y), "u_slices": grid.slices}


def slice_table(grid: gridmod.Grid) -> np.ndarray:
    """The depths where listing 4 steps, NaN-padded to 2^k - 1 (grid.slice_from_table)."""
    return gridmod._table_for(grid.slice_scale, grid.slice_bias, grid.slices)


def count_cells(b: Build) -> list:
    """Each visible light's box and cell count, their scan, and the host step that reads
    the entry count back and sizes the fill by it."""
    g, n = b.grid, len(b.lights)
    table = slice_table(g)
    boxes = Pass("build_bin", "build_bin.comp",
                 reads=("counters", "light_rect", "light_depth", "slice_table"),
                 writes={"boxes": steps.words(6 * n), "cell_counts": steps.words(n)},
                 groups=steps.groups(steps.blocks(n)), defines=dict(COUNTER_DEFINES, BIN_STEP=0),
                 uniforms=dict(bin_uniforms(g), u_capacity=n, u_tile=float(g.tile),
                               u_inv_tile=1.0 / float(g.tile),
                               u_depth_lo_scale=1.0 - limits.SLICE_DEPTH_REL_MARGIN,
                               u_depth_hi_scale=1.0 + limits.SLICE_DEPTH_REL_MARGIN,
                               u_table_size=len(table)),
                 sources={"counters": COUNTERS, "light_rect": "gb_light_rect",
                          "light_depth": "gb_light_depth", "slice_table": "gb_slice_table",
                          "boxes": "gb_boxes", "cell_counts": "gb_cell_counts"})

    def sized(read):
        return {}, fill_cells(b, int(read[COUNTERS][ENTRIES]))
    return [boxes] + steps.scan("build_bin", "gb_cell_counts", "gb_light_first", n,
                                            COUNTERS, ENTRIES) + [HostStep("build_bin_entries", (COUNTERS,), sized)]


def fill_cells(b: Build, entries: int) -> list:
    """The entries (cell, light) in light order, stable-sorted by cell; the ranges; then the
    host step that reads the longest list back and hands over to the shading."""
    g, n = b.grid, len(b.lights)
    limits.check_buffer("light index list", 4 * entries)   # (the CPU build's refusal, same words)
    expand = Pass("build_bin", "build_bin.comp", reads=("counters", "boxes", "light_first"),
                  writes={"entry_cells": steps.words(entries), "entry_lights": steps.words(entries)},
                  groups=steps.groups(steps.blocks(entries)), defines=dict(COUNTER_DEFINES, BIN_STEP=1),
                  uniforms=dict(bin_uniforms(g), u_capacity=n),
                  sources={"counters": COUNTERS, "boxes": "gb_boxes", "light_first": "gb_light_first",
                           "entry_cells": "gb_entry_cells", "entry_lights": "gb_entry_lights"})
    ranges = Pass("build_bin", "build_bin.comp", reads=("sorted_cells",),
                  writes={"counters": Buffer(16, steps.U32),
                          "ranges": Buffer(g.cells * layouts.CELL_RANGE.itemsize, layouts.CELL_RANGE)},
                  groups=steps.groups(steps.blocks(g.cells)), defines=dict(COUNTER_DEFINES, BIN_STEP=2),
                  uniforms=dict(bin_uniforms(g), u_cells=g.cells),
                  sources={"counters": COUNTERS, "sorted_cells": "gb_sorted_cells"})
    b.stats["list_entries"] = entries
    cell_bits = max(int(g.cells - 1).bit_length(), 1)
    return ([expand] + steps.sort("build_bin", "gb_entry_cells", "gb_entry_lights", "gb_sorted_cells",
                                  "entries", max(entries, 1), cell_bits, COUNTERS, ENTRIES)
            + [ranges, HostStep("build_bin_longest", (COUNTERS,), lambda read: ({}, b.data["shade"](
                int(read[COUNTERS][LONGEST]))))])


def readback_step(b: Build) -> HostStep:
    """The GPU-built ranges and entries read back into b.buffers (figures only: the maps,
    the wave replay and the tests read the frame's structures from there)."""
    def run(read):
        b.buffers["ranges"] = read["ranges"].copy()
        b.buffers["entries"] = read["entries"][:b.stats["list_entries"]].copy()
        return {}, []
    return HostStep("build_readback", ("ranges", "entries"), run, figures=True)


def unbuilt_lights(frame: FrameInput) -> lightsmod.PreparedLights:
    """The frame's lights before the GPU has culled them: no rows yet, and every scene
    light's type, so that the shaders compile each shape the cull may keep (the renderer
    reads the types before the passes run); the pack step replaces it."""
    empty = lightsmod.pack(frame.lights[:0], frame.camera, np.zeros(0, np.uint64))
    empty.type = np.unique(frame.lights["type"]).astype(np.uint8)
    return empty
