"""`python -m app.bench cpu --c-reference [--threads N]`: the C reference (hybrid_ref.c, one
thread) and our numba CPU stage (one thread unless --threads says more: the issue's bar is
plain single-threaded C, whatever ours runs on) on the same frame, interleaved (C, numba, C,
numba, ... each with its
own buffers reused frame to frame), so a change of the shared machine's load falls on both
alike; per step and in total min / median of each and the ratio numba / C.

    step            C (hybrid_ref.c)        ours (technique.build's StageTimes)
    cull            cull                    cull
    sort + gather   sort + gather           sort + pack (the pack's ms also hold the
                                            technique's list/tree buffer glue)
    bin             bin                     bin
    plan + build    plan + build            build (listing 2 and the trees in one pass)
    total           the sum                 the sum (bench cpu's total)

Before timing, the warm-up frame's outputs of both are compared bit for bit (GPU rows, ids,
rectangles, depth ranges, entries, ranges, nodes): "identical" in the output.

--lean-reference adds a third, lean_ref.c (the stage as the tree paper describes it, written
apart from the lab: app.bench.c_reference.lean), interleaved with the two (C, numba, lean,
C, ...): per step its min / median, numba / lean of the mins and medians, and the median
and quartiles of the frames' own ratios (each numba frame against the lean frame after
it); and how its warm-up frame's per-cell light sets compare with ours ("lean" in the
result).
"""
from __future__ import annotations

from dataclasses import dataclass
import json
import os
import sys

import numpy as np

from cpu_prep import threads as cpu_threads, using_threads

from ...errors import UserError
from ...results import stats
from ..study import CountSeries, Study
from . import STEPS, CReference

TECHNIQUES = ("hybrid", "clustered")
ROWS = {"cull": (("cull",), ("cull",)),
        "sort + gather": (("sort", "gather"), ("sort", "pack")),
        "bin": (("bin",), ("bin",)),
        "plan + build": (("plan", "build"), ("build",))}
# options the C reference does not do: they must keep their defaults
_FIXED = ("sort_buckets", "tree_build", "cap_policy", "stochastic", "build", "duplicated")


def check_options(technique, opts) -> None:
    d, default = opts.as_dict(), technique.resolve_options(None).as_dict()
    off = [k for k in _FIXED if k in d and d[k] != default[k]]
    if off:
        raise UserError(f"--c-reference: the C reference builds the default CPU stage only; "
                        f"drop {', '.join('--' + k.replace('_', '-') for k in off)}")


def differences(c, b, hybrid: bool) -> list[str]:
    """Names of the outputs where the C frame `c` and our build `b` differ (bit for bit)."""
    pl = b.lights
    pairs = {"ids": (c.ids, pl.ids), "gpu rows": (c.gpu, pl.gpu), "rects": (c.rect, pl.rect),
             "depth_lo": (c.depth_lo, pl.depth_lo), "depth_hi": (c.depth_hi, pl.depth_hi),
             "entries": (c.entries, b.buffers["entries"]), "ranges": (c.ranges, b.buffers["ranges"])}
    if hybrid:
        pairs["nodes"] = (c.nodes, b.buffers["nodes"])
    out = []
    for k, (x, y) in pairs.items():
        x, y = np.asarray(x), np.asarray(y)
        if x.shape != y.shape or x.dtype != y.dtype or x.tobytes() != y.tobytes():
            out.append(k)
    return out


def compare(technique, scene, size, opts, repeat: int, frame: int = 0, frames: int = 64,
            progress=None, lean: bool = False) -> dict:
    """The comparison's result (the --json object): per row of ROWS and 'total', and per C
    step, min / median ms of each side and the ratios numba / C of the mins and medians, the
    median of the frames' own total ratios (each numba frame against the C frame before
    it), whether the outputs are identical, the sizes."""
    from cpu_prep.arena import Arena
    from cpu_prep.camera import frame_camera
    from cpu_prep import grid as gridmod
    from ...pipeline.passes import FrameInput
    from ...results import CPU_STAGES
    hybrid = technique.name == "hybrid"
    w, h = size
    cam = frame_camera(scene.camera_at(frame, frames), w, h)
    max_depth = scene.max_depth or cam.far
    fi = FrameInput(scene.lights, cam, max_depth, Arena())
    ref = CReference()
    lref = _lean_reference() if lean else None
    grid = gridmod.make_grid(cam, opts.tile, opts.slices, max_depth, opts.near_slice_depth)
    load = [round(v, 2) for v in os.getloadavg()]
    kw = dict(tile=opts.tile, slices=opts.slices, near_slice_depth=opts.near_slice_depth,
              max_depth=max_depth, hybrid=hybrid)
    if hybrid:
        kw.update(lights_per_leaf=opts.lights_per_leaf, max_leaves=opts.max_leaves,
                  radius_scale=opts.radius_scale)
    try:
        c = ref.frame(scene.lights, cam, **kw)          # warm-up (and the input's refusal)
        b = technique.build(fi, opts)                   # warm-up (numba's JIT / cache load)
        differ = differences(c, b, hybrid)
        lkw = dict(lights_per_leaf=opts.lights_per_leaf, max_leaves=opts.max_leaves,
                   radius_scale=opts.radius_scale) if hybrid else {}
        lists = _lean_lists(lref.frame(scene.lights, cam, grid, max_depth, **lkw), grid, b) \
            if lean else None
        cs = {k: [] for k in STEPS + ("total",)}
        ns = {k: [] for k in CPU_STAGES + ("total",)}
        ls = {k: [] for k in STEPS + ("total",)}
        for i in range(repeat):
            if progress:
                progress(i + 1, repeat, f"C and numba {technique.name} frames")
            c = ref.frame(scene.lights, cam, **kw)
            for k in STEPS:
                cs[k].append(c.ms[k])
            cs["total"].append(c.total_ms)
            ms = technique.build(fi, opts).times.ms    # (bench cpu's stages and total)
            for k in CPU_STAGES:
                ns[k].append(float(ms.get(k, 0.0)))
            ns["total"].append(float(sum(ms.values())))
            if lean:
                f = lref.frame(scene.lights, cam, grid, max_depth, **lkw)
                for k in STEPS:
                    ls[k].append(f.ms[k])
                # clustered: the lean C's steps up to its lists (it plans and builds anyway)
                ls["total"].append(sum(f.ms[k] for k in (STEPS if hybrid else STEPS[:4])))
        visible = int(c.ids.shape[0])          # (c's arrays are the C side's: read them here)
        sizes = {"cells": int(len(c.ranges)), "list_entries": int(len(c.entries))}
        if hybrid:
            sizes.update(nodes=int(len(c.nodes)), trees=int(c.is_tree.sum()))
    finally:
        ref.close()
        if lref is not None:
            lref.close()
    rows = {}
    for name, (ck, nk) in list(ROWS.items()) + [("total", (("total",), ("total",)))]:
        if name == "plan + build" and not hybrid:
            continue                           # clustered: no plan, no trees
        cv = np.sum([cs[k] for k in ck], axis=0)
        nv = np.sum([ns[k] for k in nk], axis=0)
        rows[name] = _row(cv, nv)
    rows["total"]["paired_ratio_median"] = round(float(np.median(
        np.asarray(ns["total"]) / np.maximum(cs["total"], 1e-9))), 3)
    return {"technique": technique.name, "scene": scene.name, "size": [w, h],
            "lights": int(len(scene.lights)), "visible": visible,
            "repeat": repeat, "threads": cpu_threads(), "options": opts.as_dict(), "sizes": sizes,
            "identical": not differ, "differ": differ,
            "c_library": str(ref.path),
            "rows": rows,
            "c_steps": _steps(cs, STEPS if hybrid else STEPS[:4]),
            "numba_stages": _steps(ns, CPU_STAGES),
            "load": {"before": load, "after": [round(v, 2) for v in os.getloadavg()]},
            **({"lean": _lean_result(ls, ns, hybrid, lists, lref.path)} if lean else {})}


def _lean_reference():
    from .lean import LeanReference
    return LeanReference()


def _lean_lists(f, grid, b) -> dict:
    """The lean frame's per-cell light sets against our build's (lean.list_differences;
    our CSR lists made again from our build's rectangles and depth ranges)."""
    from cpu_prep import grid as gridmod
    from .lean import list_differences
    pl = b.lights
    offsets, entries, _ = gridmod.bin_rects(grid, pl.rect, pl.depth_lo, pl.depth_hi)
    d = list_differences(f, pl.ids, offsets, entries)
    d["lean_only"], d["ours_only"] = len(d["lean_only"]), len(d["ours_only"])
    d["lean_visible"], d["our_visible"] = int(len(f.ids)), int(len(pl.ids))
    return d


def _lean_result(ls, ns, hybrid: bool, lists: dict, path) -> dict:
    rows = {}
    for name, (ck, nk) in list(ROWS.items()) + [("total", (("total",), ("total",)))]:
        if name == "plan + build" and not hybrid:
            continue
        lv = np.sum([ls[k] for k in ck], axis=0)
        nv = np.sum([ns[k] for k in nk], axis=0)
        r = _row(lv, nv)
        rows[name] = {k.replace("c_", "lean_", 1) if k.startswith("c_") else k: v
                      for k, v in r.items()}
        paired = nv / np.maximum(lv, 1e-9)         # each numba frame against its lean frame
        rows[name]["paired_ratio_median"] = round(float(np.median(paired)), 3)
        rows[name]["paired_ratio_quartiles"] = [round(float(q), 3)
                                                for q in np.percentile(paired, (25, 75))]
    return {"library": str(path), "rows": rows,
            "steps": _steps(ls, STEPS if hybrid else STEPS[:4]), "lists": lists}


def _steps(samples: dict, keys) -> dict:
    return {k: {"min_ms": round(float(np.min(samples[k])), 4),
                "median_ms": round(float(np.median(samples[k])), 4)} for k in keys}


def _row(cv, nv) -> dict:
    (cmed, cmin, cmax), (nmed, nmin, nmax) = stats(cv), stats(nv)
    ratio = lambda a, b: round(a / b, 3) if b > 0 else None
    return {"c_min_ms": round(cmin, 4), "c_median_ms": round(cmed, 4), "c_max_ms": round(cmax, 4),
            "numba_min_ms": round(nmin, 4), "numba_median_ms": round(nmed, 4),
            "numba_max_ms": round(nmax, 4),
            "ratio_min": ratio(nmin, cmin), "ratio_median": ratio(nmed, cmed)}


# ---- the benchmark's study (--quick / --full: CReferenceStudy) ------------------------------

STUDY = "c_reference"


def study_rows(scene_name: str, counts, size, repeat: int, threads=(1, 2), progress=None,
               log=None) -> list[dict]:
    """One results.csv row (study "c_reference") per technique of TECHNIQUES, count and
    numba thread count: compare()'s figures, ours in the CPU stage columns (medians; the
    total's min and max), the C's and the ratios in `stats`.  A scene of other lights than
    points, or no C compiler: no rows, and a line on `log` saying why."""
    from scenes import load_scene
    from ...techniques import get
    jobs = [(n, t, k) for n in counts for t in TECHNIQUES for k in threads]
    rows = []
    for i, (n, name, k) in enumerate(jobs):
        technique = get(name)
        if progress:
            progress(i + 1, len(jobs), f"{STUDY} {scene_name} {n} lights {name}, numba on "
                                       f"{k} thread(s) against C on one at {size[0]}x{size[1]}")
        opts = technique.resolve_options(None)
        try:
            with using_threads(k):
                r = compare(technique, load_scene(scene_name, lights=int(n)), size, opts, repeat)
        except UserError as exc:
            if log is not None:
                log.write(f"bench: {STUDY}: skipped ({exc})\n")
            return []
        rows.append(_results_row(technique, scene_name, n, size, repeat, opts, r))
    return rows


@dataclass(frozen=True)
class CReferenceConfig(CountSeries):
    """The sweep's comparison (in the CPU series' scene at its size), C and numba
    interleaved frame by frame, numba on each of `threads`; skipped, with a line, where the
    scene has other lights than points or no C compiler is found."""
    threads: tuple[int, ...]


class CReferenceStudy(Study):
    """The CPU stage of TECHNIQUES against the plain C reference (study_rows: results.csv
    study "c_reference", the report's CPU page); a scene it cannot take: none, with a line."""
    name = STUDY
    sections = ("cpu",)
    Config = CReferenceConfig

    def run(self, out, sweep) -> list[dict]:
        c = self.config
        if not c.lights:
            return []
        return study_rows(c.scene, c.lights, c.size, c.repeat, c.threads,
                          progress=sweep.progress, log=sweep.log)


def _results_row(technique, scene_name, n, size, repeat, opts, r) -> dict:
    from ..measure import cpu_study_row
    from ...results import CPU_STAGES
    t = r["rows"]["total"]
    row = cpu_study_row(STUDY, technique, scene_name, n, r["visible"], size, repeat, opts)
    for k in CPU_STAGES:
        row[f"cpu_{k}_ms"] = r["numba_stages"].get(k, {}).get("median_ms", 0.0)
    row["cpu_total_ms"], row["cpu_total_min_ms"], row["cpu_total_max_ms"] = \
        t["numba_median_ms"], t["numba_min_ms"], t["numba_max_ms"]
    row["stats"] = json.dumps({"threads": r["threads"], "identical": r["identical"],
                               "c_ms": t["c_median_ms"], "c_min_ms": t["c_min_ms"],
                               "c_max_ms": t["c_max_ms"], "ratio_min": t["ratio_min"],
                               "ratio_median": t["ratio_median"],
                               "paired_ratio_median": t["paired_ratio_median"],
                               "c_steps": r["c_steps"]}, sort_keys=True)
    return row


def print_result(r: dict, as_json: bool) -> None:
    if as_json:
        print(json.dumps(r))
        return
    s = r["sizes"]
    print(f"{r['technique']} on {r['scene']} at {r['size'][0]}x{r['size'][1]}: {r['lights']} "
          f"lights, {r['visible']} visible; {r['repeat']} frames each after a warm-up, C and "
          f"numba interleaved; C on one thread, numba on {r['threads']}")
    print("  " + ", ".join(f"{k} {v:,}" for k, v in s.items()))
    print(f"  outputs bit for bit identical: "
          + ("yes" if r["identical"] else f"NO ({', '.join(r['differ'])} differ)"))
    print(f"{'step':14} {'C min':>8} {'C med':>8} {'numba min':>10} {'numba med':>10} "
          f"{'ratio min':>10} {'ratio med':>10}")
    for name, v in r["rows"].items():
        f = lambda x: f"{x:.2f}x" if x is not None else "-"
        print(f"{name:14} {v['c_min_ms']:8.3f} {v['c_median_ms']:8.3f} {v['numba_min_ms']:10.3f} "
              f"{v['numba_median_ms']:10.3f} {f(v['ratio_min']):>10} {f(v['ratio_median']):>10}")
    print(f"total ratio numba / C, median of the frames' own ratios: "
          f"{r['rows']['total']['paired_ratio_median']:.2f}x")
    for who, key in (("C steps", "c_steps"), ("numba stages", "numba_stages")):
        print(f"{who} (ms min / median): " + ", ".join(
            f"{k} {v['min_ms']:.3f} / {v['median_ms']:.3f}" for k, v in r[key].items()))
    if "lean" in r:
        _print_lean(r["lean"])
    print("load average (1, 5, 15 min) before / after: "
          f"{' '.join(map(str, r['load']['before']))} / {' '.join(map(str, r['load']['after']))}")


def main(args, threads, technique, opts) -> None:
    """cpu_main's --c-reference branch (args: its namespace)."""
    from ... import cli
    if technique.name not in TECHNIQUES:
        raise UserError(f"--c-reference: the C reference is of {' and '.join(TECHNIQUES)}'s "
                        f"CPU stage only (got '{technique.name}')")
    if len(threads) != 1 or threads[0] < 1:
        raise UserError("--c-reference: --threads is one count >= 1 (numba's; the C reference "
                        "is single-threaded)")
    check_options(technique, opts)
    scene = cli.load_scene_args(args)
    size = tuple(args.size or scene.resolution)
    log = (lambda i, total, what: sys.stderr.write(f"[{i}/{total}] {what}\n")) if not args.json else None
    with using_threads(threads[0]):
        r = compare(technique, scene, size, opts, args.repeat, args.frame, args.frames,
                    progress=log, lean=getattr(args, "lean_reference", False))
    r["scene"] = args.scene
    print_result(r, args.json)


def _print_lean(d: dict) -> None:
    li = d["lists"]
    print(f"lean C (lean_ref.c, one thread), interleaved with both: {li['lean_visible']:,} "
          f"visible (ours {li['our_visible']:,}), {li['lean_entries']:,} list entries (ours "
          f"{li['our_entries']:,}); {li['same_cells']:,} of {li['cells']:,} cells hold the "
          f"same light set as ours, {li['ours_only']:,} (cell, light) pairs ours only (its "
          f"margins), {li['lean_only']:,} the lean C's only")
    print(f"{'step':14} {'lean min':>9} {'lean med':>9} {'numba min':>10} {'numba med':>10} "
          f"{'ratio min':>10} {'ratio med':>10} {'paired (quartiles)':>19}")
    f = lambda x: f"{x:.2f}x" if x is not None else "-"
    for name, v in d["rows"].items():
        q = v["paired_ratio_quartiles"]
        print(f"{name:14} {v['lean_min_ms']:9.3f} {v['lean_median_ms']:9.3f} "
              f"{v['numba_min_ms']:10.3f} {v['numba_median_ms']:10.3f} "
              f"{f(v['ratio_min']):>10} {f(v['ratio_median']):>10} "
              f"{v['paired_ratio_median']:6.2f}x ({q[0]:.2f}-{q[1]:.2f})")
    t = d["rows"]["total"]
    q = t["paired_ratio_quartiles"]
    print(f"total ratio numba / lean C, the frames' own ratios: median {t['paired_ratio_median']:.2f}x "
          f"(quartiles {q[0]:.2f}-{q[1]:.2f}x)")
    print("lean C steps (ms min / median): " + ", ".join(
        f"{k} {v['min_ms']:.3f} / {v['median_ms']:.3f}" for k, v in d["steps"].items()))
