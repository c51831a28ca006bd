"""hybrid (O'Donnell & Chajdas 2017, 3.3): the clustered 2.5D grid, each cell a list or a
light tree by the overlap heuristic of listing 2 (cpu_prep.hybrid).  A list is a one-node
tree whose root is a leaf, so one buffer layout serves both.

    ranges[cell] = (first node, node count: 1 = list, >1 = tree; top bit: listing 2 chose a
                    tree) -> nodes[] -> entries[] -> lights[]

The shading pass (glsl/shade_hybrid.comp) takes the paper's three wave paths: a) every lane
a list, b) every lane a tree (from shared memory when the group shares one), c) mixed;
`specialised=False` runs the one general traversal instead, so the report can set each
path's wave iterations and node visits against it.  Waves are classified by listing 2's
choice, not by the stored structure (a chosen list of more than 65,535 lights is stored as a
small tree of lists).  `scalarize` walks the wave's distinct list cells in path a) (Drobot
2017's container scalarization).  `tree_build` (TreeOptions): the tree cells built
bottom-up (full trees) or top-down (cpu_prep.tree_topdown; a top-down cell that stays one
leaf is read as a list by structure, as a list of any cell is).
"""
from dataclasses import dataclass
import json

import numpy as np

from cpu_prep import hybrid as hybridmod, layouts

from ...model import waves
from ...pipeline.passes import OUT_STATS, WAVE_DIM, WAVE_STATS, HostStep
from ..base import Technique, cell_head, entry_list, prepare_binned
from ..gpu_build import BuildOptions, build_trees, on_gpu
from ..options import (CapOptions, ListOptions, ScalarizeOptions, SliceOptions, StochasticOptions, TreeOptions,
                      WaveOptions, FeatureVariantOptions, option)
from .. import variants
from ...pipeline import features as feat
from ..blocks import (add_shared_load, live_groups, one_tree_groups, study_notes, tree_buffers,
                     tree_passes)

CELL_TREE_BIT = np.uint32(1 << 31)     # a cell's count word: listing 2 chose a tree


class Hybrid(Technique, register_at=50):
    name = "hybrid"
    summary = "2.5D grid, each cell a list or a tree (listing 2 heuristic)"
    views = Technique.views + ("tiles", "slices", "classes", "variants")
    glsl = {"hybrid_cells.glsl": layouts.glsl_defines({"CELL_TREE_BIT": CELL_TREE_BIT})}

    @dataclass(frozen=True)
    class Options(SliceOptions, ListOptions, TreeOptions, WaveOptions, ScalarizeOptions,
                  CapOptions, StochasticOptions, BuildOptions, FeatureVariantOptions):
        radius_scale: float = option(1.0, "listing 2's cell.radius = scale x half the cell's "
                                          "depth extent (undefined in the paper)",
                                     lo=1e-3, hi=1e3, study=(0.5, 1.0, 2.0, 4.0))
        specialised: bool = option(True, "the paper's three wave paths (all lists, all trees "
                                         "with the shared-memory tree, mixed); off: one general "
                                         "traversal for every wave", study=(True, False))

    def build(self, frame, opts):
        if on_gpu(opts):
            return build_trees(frame, opts, opts.slices, lambda b: self.passes(b, opts), CELL_TREE_BIT)
        b, offsets, entries = prepare_binned(frame, opts, opts.slices, opts.sort_buckets)
        with b.times.stage("build"):      # listing 2's choice and the trees, one pass
            *built, is_tree = hybridmod.plan_and_build(
                b.grid, offsets, entries, b.lights.depth_lo, b.lights.depth_hi, frame.max_depth,
                opts.radius_scale, opts.lights_per_leaf, opts.max_leaves, frame.arena,
                opts.tree_build)
        leaves = tree_buffers(b, offsets, entries, is_tree, opts, frame.arena, built)
        with b.times.stage("pack"):       # the choice, for the wave classification
            b.buffers["ranges"]["offset_count"][:, 1] |= is_tree.astype(np.uint32) * CELL_TREE_BIT
        used = np.diff(offsets) > 0
        b.stats.update(trees=int((is_tree & used).sum()), lists=int((~is_tree & used).sum()),
                       lists_stored_as_trees=int((~is_tree & (leaves > 1)).sum()))
        return b

    def passes(self, build, opts):
        shade = tree_passes(build, opts, "shade_hybrid.comp", native_wave=opts.native_wave,
                            defines={"SPECIALISED": int(opts.specialised),
                                     "SCALARIZED": int(opts.scalarize)})
        steps = shade + [HostStep("wave cases", (WAVE_STATS, OUT_STATS),
                                  lambda got: _case_counters(build, got[WAVE_STATS], got[OUT_STATS]),
                                  figures=True)]
        return variants.with_variants(build, opts, steps, variants.CellSource(
            variants.CELL_NODES, ("ranges", "entries", "nodes"), count_mask=int(~CELL_TREE_BIT),
            mask_defines=lambda m: {"CELL_KINDS": (m >> feat.CELL_KIND_SHIFT) & 3}))

    def cull_figures(self, frame, width):
        """The feature variants' passes when on (the cells are CPU-built)."""
        return variants.figures_if_on(frame, width, variants.node_scans, {})

    def report_notes(self, rows):
        """Per wave path: the waves, their scalar iterations and node visits, against the
        unspecialised loop (app/report/notes.py)."""
        return _notes(rows)

    def wave_program(self, frame, width):
        """shade_hybrid.comp: the cell record, then (specialised) the group vote and one of
        the three paths per wave, else the general traversal for every lane."""
        prog = waves.Program(frame, width)
        b, opts = frame.build, frame.opts
        lanes = np.nonzero(frame.shading)[0]
        rng = b.buffers["ranges"]["offset_count"].astype(np.int64)
        cell = frame.cell[lanes]
        first, count = rng[cell, 0], rng[cell, 1] & ~np.int64(CELL_TREE_BIT)
        nodes = b.buffers["nodes"]
        lid = entry_list(prog, b.buffers["entries"], opts.duplicated)
        prog.add(lanes, head=cell_head(prog, lanes))
        if not opts.specialised:
            prog.add_tree(lanes, first, count, nodes, lid)
            return prog
        tree = count > 1
        group = frame.group[lanes]
        # the group vote (groupReduce: 4 barriers): one tree, read from shared memory?
        prog.barriers += 4 * int(live_groups(prog).sum())
        one = one_tree_groups(group[tree], cell[tree], count[tree], prog.groups, group[~tree])
        shared = one[group]
        prog.barriers += 5 * int(one.sum())          # the base's vote, the load's barrier
        gfirst = np.zeros(prog.groups, np.int64)
        gcount = np.zeros(prog.groups, np.int64)
        gfirst[group[shared]], gcount[group[shared]] = first[shared], count[shared]
        add_shared_load(prog, gfirst, gcount, one)
        prog.add_tree(lanes[shared], first[shared], count[shared], nodes, lid, step0=64,
                       shared=True)
        # the other groups: per wave all lists, all trees or mixed (native: a wave vote)
        rest = ~shared
        w = prog.wave[lanes]
        has_tree = np.zeros(prog.waves, bool)
        has_tree[w[rest & tree]] = True
        has_other = np.zeros(prog.waves, bool)
        has_other[w[rest & ~tree]] = True
        mixed = has_tree[w] & has_other[w]
        lists = rest & ~tree
        if opts.scalarize:          # all-list waves walk their distinct list cells (rounds)
            walk = lists & ~mixed
            r = waves.rounds(prog, lanes[walk], cell[walk])
            v = waves.tree_visits(frame.position[lanes[walk], 3], first[walk],
                                  np.minimum(count[walk], 1), nodes)
            prog.add(lanes[walk][v[:, 0]], step=1 + r[v[:, 0]],
                     head=("node", "nodes", v[:, 2] * 16, 16, True), lights=(lid, v[:, 3], v[:, 4], True))
            lists &= mixed
        prog.add_tree(lanes[lists], first[lists], count[lists], nodes, lid)
        trees = rest & tree
        prog.add_tree(lanes[trees], first[trees], count[trees], nodes, lid,
                       branch=1)               # in a mixed wave, after its list lanes
        return prog


def _case_counters(build, waves, pixels):
    """Meta stats per wave path (untimed, after the frame): waves, mean scalar iterations and
    tree nodes visited per pixel, by listing 2's classification."""
    w, h = build.frame.size
    gx, gy = -(-w // WAVE_DIM), -(-h // WAVE_DIM)
    wv = np.asarray(waves).view(layouts.WAVE_STATS).reshape(gy, gx)
    st = np.asarray(pixels).view(layouts.PIXEL_STATS).reshape(h, w)
    pad = lambda a: np.pad(a.astype(np.float64), ((0, gy * WAVE_DIM - h), (0, gx * WAVE_DIM - w)))
    per_group = lambda a: pad(a).reshape(gy, WAVE_DIM, gx, WAVE_DIM).sum((1, 3))
    nodes, busy = per_group(st["nodes"]), per_group((st["evaluated"] + st["nodes"]) > 0)
    case = wv["case_bits"] & layouts.CASE_MIXED
    for k, name in layouts.CASES.items():
        m = case == k
        build.stats[f"waves_{name}"] = int(m.sum())
        build.stats[f"iterations_{name}"] = float(wv["iterations"][m].mean()) if m.any() else 0.0
        build.stats[f"nodes_{name}"] = float(nodes[m].sum() / max(busy[m].sum(), 1.0))
    build.stats["waves_shared_tree"] = int(((wv["case_bits"] & layouts.CASE_SHARED_TREE) != 0).sum())
    return {}, []


def _notes(rows) -> tuple[str, str]:
    def stats(sub):
        out = {}
        for r in sub:
            for k, v in json.loads(r.get("stats") or "{}").items():
                out.setdefault(k, []).append(v)
        return {k: float(np.mean(v)) for k, v in out.items()}

    text = ["The paper's three wave paths, classified by listing 2's choice per cell (tree "
            "paper figure 3; mean over the camera path):", "",
            "| scene, lights | cells list / tree | waves list / tree / mixed | scalar iterations "
            "per wave, list / tree / mixed | nodes visited per pixel, list / tree / mixed |",
            "|---|---|---|---|---|"]
    path = [r for r in rows if r["study"] == "path"]
    for key in dict.fromkeys((r["scene"], int(r["lights"])) for r in path):
        s = stats([r for r in path if (r["scene"], int(r["lights"])) == key])
        if "waves_list" not in s:
            continue
        c = list(layouts.CASES.values())
        text.append(f"| {key[0]}, {key[1]} | {s.get('lists', 0):.0f} / {s.get('trees', 0):.0f} | "
                    + " / ".join(f"{s[f'waves_{n}']:.0f}" for n in c) + " | "
                    + " / ".join(f"{s[f'iterations_{n}']:.3g}" for n in c) + " | "
                    + " / ".join(f"{s[f'nodes_{n}']:.3g}" for n in c) + " |")
    study = [r for r in rows if r["study"] == "specialised"]
    by = {bool(r["specialised"]): stats([r]) for r in study}
    if True in by and False in by:
        r0 = study[0]
        text += ["", f"Specialised paths against the one general traversal ({r0['scene']}, "
                 f"{int(r0['lights'])} lights, frame {int(r0['frame'])}):", "",
                 "| path | waves | scalar iterations, specialised / general | nodes per pixel, "
                 "specialised / general |", "|---|---|---|---|"]
        for n in layouts.CASES.values():
            a, g = by[True], by[False]
            text.append(f"| {n} | {a.get(f'waves_{n}', 0):.0f} | {a.get(f'iterations_{n}', 0):.3g} / "
                        f"{g.get(f'iterations_{n}', 0):.3g} | {a.get(f'nodes_{n}', 0):.3g} / "
                        f"{g.get(f'nodes_{n}', 0):.3g} |")
        text.append(f"\n{a.get('waves_shared_tree', 0):.0f} waves read their one tree from shared "
                    f"memory.  The GPU time of the two is in the option study above "
                    f"(`specialised`).")
    builds = study_notes(rows)
    if builds:
        text += ["", "The tree cells' build (`tree_build`):", "", builds]
    return "wave paths (tree paper 3.4)", "\n".join(text)
