"""The blocks several techniques share, each written once: what a technique imports
instead of reaching into a sibling technique's module.

    lists    list_buffers / list_reads / cell_ranges: CSR index lists per cell
             ranges[cell] = (first entry, count) -> entries[] -> lights[] (lists.glsl);
             clustered, tree and hybrid (whose list cells are one-leaf trees)
    trees    tree_buffers / tree_passes: light trees per cell (tree.glsl), tree and hybrid;
             the shared-memory tree's replay (one_tree_groups, add_shared_load) and the
             tree builds' study notes
    tiles    tile_boxes: the lights' conservative tile boxes on a 2D grid (zbin, raster)
"""
from __future__ import annotations

import numpy as np

from cpu_prep import frame as cpuframe, grid as gridmod, layouts, limits, tree as treemod

from ..pipeline.passes import WAVE_DIM
from .base import grid_uniforms, shading_passes
from .options import CPU_PREFIX


# ---- index lists per cell ----------------------------------------------------------------

def list_buffers(b, offsets, entries, duplicated: bool) -> None:
    """ranges + entries (+ duplicated light copies) of a CSR binning."""
    ranges = np.zeros(len(offsets) - 1, layouts.CELL_RANGE)
    ranges["offset_count"][:, 0] = offsets[:-1]
    ranges["offset_count"][:, 1] = np.diff(offsets)
    b.buffers["ranges"] = ranges
    b.buffers["entries"] = entries
    if duplicated:
        b.buffers["dup_lights"] = b.lights.gpu[entries]
        cpuframe.check_buffer("duplicated light lists", b.buffers["dup_lights"].nbytes)
    b.stats["list_entries"] = len(entries)
    b.longest_list = int(np.diff(offsets).max(initial=0))


def list_reads(duplicated: bool) -> tuple[str, ...]:
    """The buffers a shading pass over CSR lists reads (lists.glsl)."""
    return ("ranges", "entries") + (("dup_lights",) if duplicated else ())


def cell_ranges(build) -> np.ndarray:
    """(cells, 2) int64 (first, count) of a CPU-built CELL_RANGE buffer."""
    return build.buffers["ranges"]["offset_count"].astype(np.int64)


# ---- light trees per cell ---------------------------------------------------------------

SHARED_TREE_NODES = 128   # shared-memory copy of one tree: 128 x 16 B = 2 KiB


def tree_buffers(b, offsets, entries, is_tree, opts, arena=None, built=None):
    """built: (ranges, nodes, leaves) already made (the hybrid's cpu_prep.hybrid.plan_and_build)."""
    if built is None:
        with b.times.stage("build"):
            built = treemod.build_trees(
                offsets, entries, b.lights.depth_lo, b.lights.depth_hi, is_tree,
                opts.lights_per_leaf, opts.max_leaves, arena, opts.tree_build)
    ranges, nodes, leaves = built
    with b.times.stage("pack"):
        list_buffers(b, offsets, entries, opts.duplicated)
        b.buffers["ranges"] = ranges
        b.buffers["nodes"] = nodes
        cpuframe.check_buffer("tree nodes", nodes.nbytes)
    b.stats.update(nodes=len(nodes), trees=int((leaves > 1).sum()),
                   lists=int((leaves == 1).sum()))
    return leaves


def tree_passes(build, opts, shader: str, native_wave: bool = False, defines=None):
    """The shading pass of a technique whose cells hold trees (tree.glsl); a pixel meets at
    most its cell's lights (the leaves split the cell's list), in as many inner loops as it
    hits leaves (windows' `steps`)."""
    return shading_passes(build, shader, list_reads(opts.duplicated) + ("nodes",),
                          build.longest_list, steps=limits.NODE_MAX_SKIP + 1,
                          defines=dict(defines or {}, LIGHTS_DUPLICATED=int(opts.duplicated),
                                       SHARED_TREE_NODES=SHARED_TREE_NODES),
                          uniforms=grid_uniforms(build.grid), native_wave=native_wave)


# ---- the shared-memory tree in the wave replay (app.model.waves) -------------------------

def live_groups(prog) -> np.ndarray:
    """Per group, whether the replay walks it (a sampled replay leaves groups out)."""
    fr = prog.frame
    if fr.live is None:
        return np.ones(prog.groups, bool)
    out = np.zeros(prog.groups, bool)
    out[fr.group[fr.live]] = True
    return out


def live_pixels(frame) -> np.ndarray:
    """Every pixel of the image the replay walks, shading or not."""
    return np.arange(len(frame.cell)) if frame.live is None else np.nonzero(frame.live)[0]


def one_tree_groups(group, cell, count, groups: int, others=None) -> np.ndarray:
    """Per group, whether its lanes (group, cell, node count) all read one tree of 1 ..
    SHARED_TREE_NODES nodes and no lane of `others` (groups of shading lanes outside the
    set) is in it: the group vote of shade_tree.comp / shade_hybrid.comp's one_tree."""
    has = np.bincount(group, minlength=groups) > 0
    lo = np.full(groups, np.iinfo(np.int64).max)
    hi = np.full(groups, -1)
    np.minimum.at(lo, group, cell)
    np.maximum.at(hi, group, cell)
    big = np.zeros(groups, np.int64)
    np.maximum.at(big, group, count)
    ok = has & (lo == hi) & (big >= 1) & (big <= SHARED_TREE_NODES)
    if others is not None:
        ok &= np.bincount(others, minlength=groups) == 0
    return ok


def add_shared_load(prog, first, count, groups) -> None:
    """load_shared_tree (tree.glsl) in the groups `groups` (bool per group) of the tree at
    first[g], count[g] nodes: invocation l loads nodes l, l + 64, ..., every invocation of
    the group, shading or not (those past the image's edge are no pixel here: left out)."""
    fr = prog.frame
    px = live_pixels(fr)
    g = fr.group[px]
    px, g = px[groups[g]], g[groups[g]]
    if not len(px):
        return
    x, y = fr.pixel_xy
    local = (y[px] % WAVE_DIM) * WAVE_DIM + x[px] % WAVE_DIM
    its = -(-np.maximum(count[g] - local, 0) // 64)
    k = np.repeat(np.arange(len(px)), its)
    it = np.arange(len(k)) - np.repeat(np.cumsum(its) - its, its)
    node = first[g[k]] + local[k] + 64 * it
    prog.add(px[k], step=1 + it, head=("load", "nodes", node * 16, 16, False))


# ---- the tree builds' study (app.report.notes) ------------------------------------------

STUDY_VALUES = {"tree_build": treemod.BUILDS, "shared_tree": {0: "off", 1: "on"}}


def study_notes(rows) -> str:
    """The tree_build and shared_tree studies among one technique's results rows, as markdown:
    per value the lights evaluated and tree nodes visited per pixel, the CPU build stage (at
    the study's resolution, and at the CPU-only series' where it ran), the GPU lighting
    measured here and modelled per GPU."""
    text = []
    for name, labels in STUDY_VALUES.items():
        study = sorted((r for r in rows if r["study"] == name), key=lambda r: float(r[name]))
        if not study:
            continue
        cpu = {float(r[name]): r for r in rows if r["study"] == CPU_PREFIX + name}
        models = [k for k in study[0] if k.startswith("model_") and k.endswith("_lighting_ms")]
        r0 = study[0]
        text += [f"`{name}` ({r0['scene']}, {int(r0['lights'])} lights, frame {int(r0['frame'])}, "
                 f"{int(r0['width'])}x{int(r0['height'])}):", "",
                 "| value | lights evaluated / px | nodes visited / px | CPU build ms | CPU build ms, "
                 "CPU series | GPU lighting ms here | " + " | ".join(
                     f"modelled {k[len('model_'):-len('_lighting_ms')]} ms" for k in models) + " |",
                 "|---|---|---|---|---|---|" + "---|" * len(models)]
        for r in study:
            v = float(r[name])
            c = cpu.get(v)
            fmt = lambda x: f"{float(x):.3g}" if x == x else "-"
            text.append(f"| {labels.get(int(v), v)} | {fmt(r['evaluated_pp'])} | {fmt(r['nodes_pp'])} | "
                        f"{fmt(r['cpu_build_ms'])} | {fmt(c['cpu_build_ms']) if c else '-'} | "
                        f"{fmt(r['gpu_lighting_ms'])} | " + " | ".join(fmt(r[k]) for k in models) + " |")
        text.append("")
    return "\n".join(text).strip()


# ---- tile boxes --------------------------------------------------------------------------

def tile_boxes(pl, grid, arena=None) -> np.ndarray:
    """(N, 6) tile boxes of the sorted lights on a 2D grid from the conservative screen
    rectangles the binning uses (cpu_prep.frame.bin_cells: each shape's Mara-McGuire
    rectangle with PIXEL_MARGIN, radii grown against the float32 test)."""
    return gridmod.rect_boxes(grid, pl.rect, pl.depth_lo, pl.depth_hi, arena)
