"""`python -m app.bench cpu`: the CPU stage of one technique alone, with no GL context at
all (nothing here imports moderngl; a test checks it).

    technique.build R times after a warm-up (numba JIT): median/min/max ms of each stage
    (cull, sort, bin, build, pack) and of the total, and the build's structure sizes
    (visible lights, cells, list entries, tree nodes).

    --sweep 8192,16384,32768,65536   the same for each light count in turn: one table row
                                     (or, with --json, one object in "rows") a count, and
                                     the growth of the total from the first to the last

The machine is shared (2 cores, other work on them): compare minimums and medians over
many builds (--repeat 31 or more), never single runs.  docs/cpu_stage.md has the profile.
"""
from __future__ import annotations

import json
from typing import Callable

from cpu_prep.arena import Arena

from .. import cli
from ..errors import UserError
from ..pipeline.passes import FrameInput
from ..results import CPU_STAGES, UPLOAD, stats
from ..techniques import get
from .presets import int_list


def cpu_stage_samples(technique, scene, size, opts, repeat: int, frame: int = 0,
                      frames: int = 64, lights=None,
                      upload: Callable | None = None, warmup: int = 1) -> dict:
    """technique.build `repeat` times (after `warmup` unrecorded builds) on the scene's camera
    at `frame`: per-stage lists of ms (every stage of CPU_STAGES, 0 where a technique has
    none), 'total', and the visible light count.  `upload(build) -> ms` adds an upload stage."""
    from cpu_prep.camera import frame_camera
    w, h = size
    cam = frame_camera(scene.camera_at(frame, frames), w, h)
    lights = scene.lights if lights is None else lights
    opts = technique.resolve_options(opts)
    # one arena across the repeats: the frame-to-frame reuse an engine (and the Renderer) has
    fi = FrameInput(lights, cam, scene.max_depth or cam.far, Arena())
    for _ in range(warmup):
        technique.build(fi, opts)
    stages = list(CPU_STAGES) + ([UPLOAD] if upload else [])
    out = {k: [] for k in stages + ["total"]}
    visible, sizes = 0, {}
    for _ in range(repeat):
        b = technique.build(fi, opts)
        ms = dict(b.times.ms)
        if upload:
            ms[UPLOAD] = upload(b)
        for k in stages:
            out[k].append(float(ms.get(k, 0.0)))
        out["total"].append(float(sum(ms.values())))
        visible = int(b.stats.get("visible_lights", 0))
        sizes = {k: int(v) for k, v in b.stats.items() if k in SIZE_STATS}
    out["visible"] = visible
    out["sizes"] = sizes
    return out


# the build statistics worth printing beside the times (app.techniques: Build.stats)
SIZE_STATS = ("cells", "list_entries", "nodes", "trees", "lists")


def set_cpu_threads(n: int) -> int:
    """Run the CPU stage's numba kernels on n threads (0: leave numba's default); returns
    the count in use."""
    import numba
    if n > 0:
        numba.set_num_threads(min(int(n), numba.config.NUMBA_NUM_THREADS))
    return int(numba.get_num_threads())


def cpu_main(argv) -> None:
    p = cli.Parser(prog="python -m app.bench cpu",
                   description="CPU stage of one technique, no GL context")
    cli.add_scene_args(p)
    p.add_argument("--technique", default="hybrid", help="technique id")
    p.add_argument("--frame", type=int, default=0, help="camera path frame (of --frames)")
    p.add_argument("--frames", type=int, default=64, help="length of the camera path loop")
    p.add_argument("--repeat", type=int, default=9, help="measured builds (after one warm-up)")
    p.add_argument("--threads", type=int, default=1,
                   help="numba threads of the CPU stage (default 1, as the paper; 0: all)")
    p.add_argument("--sweep", metavar="N,N,...",
                   help="light counts to run in turn (instead of --lights): one row each")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    cli.add_option_args(p)
    args = p.parse_args(argv)
    if args.repeat < 1 or args.frames < 1 or args.frame < 0 or args.threads < 0:
        raise UserError("--repeat and --frames must be >= 1, --frame and --threads >= 0")
    technique = get(args.technique)
    opts = cli.options_for(technique, args)
    threads = set_cpu_threads(args.threads)
    counts = list(int_list(args.sweep, "--sweep")) if args.sweep else [args.lights]
    keys = list(CPU_STAGES) + ["total"]
    rows = []
    for n in counts:
        args.lights = n
        scene = cli.load_scene_args(args)
        size = tuple(args.size or scene.resolution)
        s = cpu_stage_samples(technique, scene, size, opts, args.repeat, args.frame, args.frames)
        st = {k: stats(s[k]) for k in keys}
        rows.append({
            "technique": technique.name, "scene": args.scene, "size": list(size),
            "lights": int(len(scene.lights)), "visible": s["visible"], "repeat": args.repeat,
            "threads": threads,
            "options": opts.as_dict(),
            "sizes": s["sizes"],
            "median_ms": {k: round(st[k][0], 4) for k in keys},
            "min_ms": {k: round(st[k][1], 4) for k in keys},
            "max_ms": {k: round(st[k][2], 4) for k in keys},
        })
    if not args.sweep:
        _print_one(rows[0], args.json)
        return
    growth = {q: round(rows[-1][q]["total"] / rows[0][q]["total"], 3) if rows[0][q]["total"] else None
              for q in ("median_ms", "min_ms")}
    if args.json:
        print(json.dumps({"technique": technique.name, "threads": threads, "rows": rows,
                          "growth": growth}))
        return
    r0 = rows[0]
    print(f"{technique.name} on {args.scene} at {r0['size'][0]}x{r0['size'][1]}, "
          f"{args.repeat} builds after a warm-up each, {threads} thread(s); ms min / median")
    print(f"{'lights':>8} {'visible':>8} " + " ".join(f"{k:>13}" for k in keys))
    for r in rows:
        print(f"{r['lights']:8d} {r['visible']:8d} " + " ".join(
            f"{r['min_ms'][k]:6.2f}/{r['median_ms'][k]:6.2f}" for k in keys))
    print(f"total growth {rows[0]['lights']} -> {rows[-1]['lights']} lights: "
          f"{growth['min_ms']}x (min), {growth['median_ms']}x (median)")


def _print_one(out: dict, as_json: bool) -> None:
    if as_json:
        print(json.dumps(out))
        return
    keys = list(CPU_STAGES) + ["total"]
    print(f"{out['technique']} on {out['scene']} at {out['size'][0]}x{out['size'][1]}: "
          f"{out['lights']} lights, {out['visible']} visible, {out['repeat']} builds after a "
          f"warm-up, {out['threads']} thread(s)")
    if out["sizes"]:
        print("  " + ", ".join(f"{k} {v:,}" for k, v in out["sizes"].items()))
    print(f"{'stage':8} {'median ms':>10} {'min ms':>10} {'max ms':>10} {'share':>7}")
    tot = out["median_ms"]["total"] or 1.0
    for k in keys:
        share = "" if k == "total" else f"{100 * out['median_ms'][k] / tot:6.1f}%"
        print(f"{k:8} {out['median_ms'][k]:10.3f} {out['min_ms'][k]:10.3f} "
              f"{out['max_ms'][k]:10.3f} {share:>7}")
