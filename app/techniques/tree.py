"""tree (O'Donnell & Chajdas 2017): one light tree per 2D screen tile over view depth.

    ranges[tile] = (first node, node count) -> nodes[] (TreeNode, depth-first, skip counts)
    leaf node -> entries[first .. first+count] -> lights[]
    1920x1080 at 48 px: 920 tiles; a tree of 64 leaves is 127 nodes = 2 KiB

`shared_tree` (on by default): the tree paper's shared-memory tree (3.4, the hybrid's tree
path), a group whose shading pixels all read one tree of at most SHARED_TREE_NODES nodes
loads it into shared memory once and traverses it from there (glsl/shade_tree.comp).  With
8x8 groups in tiles of a multiple of 8 pixels (48) every group lies in one tile and knows
its tree without a vote; other tile sizes vote (4 barriers a group).  `tree_build`: the
trees bottom-up (the paper's full trees) or top-down (cpu_prep.tree_topdown).
"""
from dataclasses import dataclass

import numpy as np

from cpu_prep import frame as cpuframe, limits, tree as treemod

from ..model import waves
from ..pipeline.passes import WAVE_DIM
from .base import Technique, cell_head, cell_ranges, entry_list, grid_uniforms, prepare_binned, shading_passes
from .clustered import list_buffers, list_reads
from .options import CPU_PREFIX, ListOptions, TileOptions, TreeOptions, option

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
                          build.data["longest_list"], steps=limits.NODE_MAX_SKIP + 1,
                          defines=dict(defines or {}, LIGHTS_DUPLICATED=int(opts.duplicated),
                                       SHARED_TREE_NODES=SHARED_TREE_NODES),
                          uniforms=grid_uniforms(build.grid), native_wave=native_wave)


class Tree(Technique):
    name = "tree"
    summary = "a light tree per 2D tile (O'Donnell & Chajdas 2017)"
    views = Technique.views + ("tiles", "classes")

    @dataclass(frozen=True)
    class Options(TileOptions, ListOptions, TreeOptions):
        shared_tree: bool = option(True, "a group whose pixels all read one tree of at "
                                         f"most {SHARED_TREE_NODES} nodes loads it into shared "
                                         "memory once and traverses it there (tree paper 3.4); "
                                         "off: every pixel reads its nodes from global memory",
                                   study=(True, False))

    def build(self, frame, opts):
        b, offsets, entries = prepare_binned(frame, opts, 1, opts.sort_buckets)
        tree_buffers(b, offsets, entries, np.ones(b.grid.cells, bool), opts, frame.arena)
        return b

    def passes(self, build, opts):
        return tree_passes(build, opts, "shade_tree.comp",
                           defines={"SHARED_TREE": int(opts.shared_tree),
                                    "TILE_ALIGNED": int(tile_aligned(opts.tile))})

    def report_notes(self, rows):
        """The tree_build and shared_tree studies' per-pixel work and costs (app/report/notes.py)."""
        return "tree builds (paper 3.2) and the shared-memory tree (3.4)", study_notes(rows)

    def wave_program(self, frame, width):
        """shade_tree.comp: the tile's record, then listing 3's traversal per lane (one step
        per node visit); shared_tree: the groups that share one tree load it (every
        invocation a node in 64), then traverse it from shared memory."""
        prog = waves.Program(frame, width)
        b, opts = frame.build, frame.opts
        lanes = np.nonzero(frame.shading)[0]
        ranges = cell_ranges(b)
        cell = frame.cell[lanes]
        first, count = ranges[cell, 0], ranges[cell, 1]
        nodes = b.buffers["nodes"]
        lid = entry_list(prog, b.buffers["entries"], opts.duplicated)
        if not opts.shared_tree:
            prog.add(lanes, head=cell_head(prog, lanes))
            prog.add_tree(lanes, first, count, nodes, lid)
            return prog
        live = live_groups(prog)
        if tile_aligned(opts.tile):
            # every invocation reads its group's tile record, from one address: no vote
            gcell = group_tiles(frame, b.grid)
            gfirst, gcount = ranges[gcell, 0], ranges[gcell, 1]
            one = live & (gcount >= 1) & (gcount <= SHARED_TREE_NODES)
            px = live_pixels(frame)
            prog.add(px, head=("cell", "ranges", gcell[frame.group[px]] * 8, 8, True))
        else:
            prog.barriers += 4 * int(live.sum())           # the vote (groupReduce)
            prog.add(lanes, head=cell_head(prog, lanes))
            group = frame.group[lanes]
            one = one_tree_groups(group, cell, count, prog.groups)
            gfirst = np.zeros(prog.groups, np.int64)
            gcount = np.zeros(prog.groups, np.int64)
            gfirst[group], gcount[group] = first, count    # one cell per `one` group
        prog.barriers += int(one.sum())                    # load_shared_tree's barrier
        add_shared_load(prog, gfirst, gcount, one)
        shared = one[frame.group[lanes]]
        prog.add_tree(lanes[shared], first[shared], count[shared], nodes, lid, step0=64,
                      shared=True)
        prog.add_tree(lanes[~shared], first[~shared], count[~shared], nodes, lid)
        return prog


def tile_aligned(tile: int) -> bool:
    """Every 8x8 group of the shading pass lies in one tile (glsl/shade_tree.comp TILE_ALIGNED)."""
    return tile % WAVE_DIM == 0


def group_tiles(frame, grid) -> np.ndarray:
    """The tile of each 8x8 group's first pixel (dispatch order; a 2D grid's cell)."""
    gx = -(-frame.size[0] // WAVE_DIM)
    g = np.arange(gx * -(-frame.size[1] // WAVE_DIM), dtype=np.int64)
    return (g // gx * WAVE_DIM // grid.tile) * grid.tiles_x + g % gx * WAVE_DIM // grid.tile


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
