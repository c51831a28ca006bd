"""`python -m app.bench --path PATH.json --out DIR`: every technique along a recorded camera
path (scenes.camera_path: `python -m app.window --record PATH.json`), one frame per key.

    python -m app.bench --path PATH.json --out DIR [--scenes S] [--lights N] [--seed S]
                        [--size WxH | --full] [--repeat R] [--techniques a,b] [--threads 1]
                        [technique options: each technique takes the ones it declares]

Per key: the reference renders first (the exactness check's), then every technique; each
frame is rendered with read-back (counters) after `--repeat` timing samples.  A warm-up frame
of every technique comes first (shader and kernel compilation), not written.  Writes:

    DIR/path.csv    one row per (frame, technique): frame, t (the recording's seconds),
                    technique, role, options, visible lights, size, samples,
                    cpu_<stage>_ms (median over the samples) and cpu_total_ms,
                    gpu_<pass>_ms for every timed pass of any technique (median; blank where a
                    technique has no such pass), gpu_lighting_ms (its timed passes but the
                    G-buffer), frame_cost_ms (CPU + lighting), setup_ms (untimed),
                    evaluated_pp and exact_pp (lights evaluated / affecting per covered
                    pixel), waste, mismatch_pixels (pixels whose contrib_count or contrib_hash
                    differ from the reference's: 0 when exact), wall_ms
    DIR/path.json   the run: command, machine, scene, size, path file, per-technique medians
    DIR/path.png    GPU lighting ms and lights evaluated per pixel along the path

The size defaults to the quick preset's (a software rasterizer renders the reference's frames
in seconds at full size); --size or --full for more.
"""
from __future__ import annotations

import json
from pathlib import Path
import statistics
import sys
import time

import numpy as np

from .. import cli
from ..errors import UserError
from ..results import STAGES, option_columns, write_csv
from . import measure
from .presets import FULL, QUICK

FIXED = ["frame", "t", "scene", "lights", "visible", "width", "height", "technique", "role", "samples"]
# the columns measure.timing_cells gives a path row (the others are the sweep's)
TIMED = [f"cpu_{s}_ms" for s in STAGES] + ["cpu_total_ms", "gpu_lighting_ms", "frame_cost_ms"]
TAIL = ["cpu_total_ms", "gpu_lighting_ms", "frame_cost_ms", "setup_ms", "evaluated_pp", "exact_pp",
        "waste", "mismatch_pixels", "wall_ms"]


def wants_path(argv) -> bool:
    """The sweep command line asks for a path run (--path PATH or --path=PATH)."""
    return any(a == "--path" or a.startswith("--path=") for a in argv)


DESCRIPTION = "every technique along a recorded camera path, per-frame CSV"


def add_args(p) -> None:
    """The path run's flags (`--path PATH.json` names the run: app.bench.main)."""
    # nargs "?": `--path --help` is the run's help, not a missing value
    p.add_argument("--path", nargs="?", metavar="PATH.json", help="camera path file "
                   "(python -m app.window --record PATH.json; required)")
    p.add_argument("--out", required=True, help="output folder (path.csv, path.json, path.png)")
    p.add_argument("--scenes", help="the scene (one builtin name or scene file; default: the "
                   "path file's scene)")
    p.add_argument("--lights", type=cli.bounded(int, 0, 4_194_304), help="light count (default: the scene's)")
    p.add_argument("--seed", type=cli.bounded(int, 0, 2**31 - 1), default=0, help="light draw seed")
    p.add_argument("--distribution", choices=("uniform", "geometry"), help="builtin scenes' light draw")
    g = p.add_mutually_exclusive_group()
    (qw, qh), (fw, fh) = QUICK.shared.size, FULL.shared.size
    g.add_argument("--quick", action="store_true", help=f"{qw}x{qh} (default)")
    g.add_argument("--full", action="store_true", help=f"{fw}x{fh}")
    p.add_argument("--size", type=cli.parse_size, help="WxH (overrides the preset's)")
    p.add_argument("--repeat", type=int, default=1, help="timing samples per frame (median)")
    p.add_argument("--techniques", help="comma-separated subset (default: every technique; the "
                   "reference always renders, for the exactness check)")
    p.add_argument("--threads", type=int, default=1, help="numba threads of the CPU stage")
    cli.add_motion_arg(p)
    cli.add_option_args(p)


def path_main(argv) -> None:
    """`bench --path ...` (the command's one parser: app.bench.main)."""
    from . import main
    main(list(argv))


def run(args, argv) -> None:
    """The path run of the parsed command line `args` (`argv`: its words, for path.json)."""
    from scenes import BUILTIN_SCENES, load_scene
    from scenes.motion import with_motion
    from ..techniques import REGISTRY, with_role
    from scenes.camera_path import load
    from ..given_options import GivenOptions
    from .cpu import set_cpu_threads
    if not args.path:
        raise UserError("--path: give the camera path file (PATH.json)")
    if args.repeat < 1:
        raise UserError("--repeat must be >= 1")
    path = load(args.path)
    scene_name = args.scenes or path.scene
    if not scene_name:
        raise UserError(f"{args.path} names no scene: give --scenes")
    if "," in scene_name:
        raise UserError(f"--scenes {scene_name}: a path run takes one scene")
    names = list(REGISTRY)
    if args.techniques:
        names = [n.strip() for n in args.techniques.split(",") if n.strip()]
        unknown = [n for n in names if n not in REGISTRY]
        if unknown or not names:
            raise UserError(f"--techniques: unknown {', '.join(unknown) or 'none given'} "
                            f"(choose from {', '.join(REGISTRY)})")
    reference = with_role("reference")
    order = [reference.name] + [n for n in names if n != reference.name]
    options = GivenOptions(cli.given_options(args))
    # each technique takes the option flags it declares and ignores the others (as the window)
    lights_n = args.lights if scene_name in BUILTIN_SCENES else None
    scene = with_motion(load_scene(scene_name, lights=lights_n, seed=args.seed,
                                   distribution=args.distribution), args.motion)
    size = tuple(args.size or (FULL.shared.size if args.full else QUICK.shared.size))
    threads = set_cpu_threads(args.threads)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    command = "python -m app.bench " + " ".join(argv)
    rows = run_path(scene, scene_name, path, size, order, names, options, args.repeat)
    write(rows, out, {"command": command, "scene": scene_name, "size": list(size),
                      "lights": int(len(scene.lights)), "path": str(args.path), "keys": len(path),
                      "repeat": args.repeat, "cpu_threads": threads,
                      "motion": scene.motion.to_dict() if scene.motion else None})


def run_path(scene, scene_name, path, size, order, written, options, repeat, log=None) -> list[dict]:
    log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
    from cpu_prep.camera import frame_camera
    from ..pipeline.renderer import Renderer
    from ..techniques import REGISTRY
    renderer = Renderer(scene, size)
    rows: list[dict] = []
    t0 = time.perf_counter()
    try:
        opts = {n: options.for_technique(REGISTRY[n])[0] for n in order}
        first = frame_camera(path.camera(0), *size)
        for n in order:                                  # warm-up: compilation, not measured
            renderer.render(REGISTRY[n], 0, opts[n], len(path), readback=False, camera=first)
        for k in range(len(path)):
            fc = frame_camera(path.camera(k), *size)
            ref = None
            for n in order:
                tech = REGISTRY[n]
                w0 = time.perf_counter()
                # frame k of the path's len(path) frames: the lights at k (Scene.lights_at)
                res = renderer.render(tech, k, opts[n], len(path), readback=True, camera=fc,
                                      samples=repeat)
                wall = (time.perf_counter() - w0) * 1e3 / repeat
                if ref is None:
                    ref = res
                if n in written:
                    rows.append(row(k, path.times[k], scene_name, len(scene.lights), size, tech,
                                    opts[n], res, ref, wall))
            log.write(f"[{k + 1}/{len(path)} {time.perf_counter() - t0:6.1f}s] frame {k}: "
                      + ", ".join(f"{r['technique']} {r['frame_cost_ms']:.1f} ms"
                                  for r in rows if r["frame"] == k) + "\n")
            log.flush()
    finally:
        renderer.release()
    return rows


def row(k, t, scene_name, lights, size, tech, opts, res, ref, wall_ms) -> dict:
    samples = measure.samples_of(res.meta)
    r = {"frame": k, "t": round(float(t), 4), "scene": scene_name, "lights": lights,
         "visible": int(res.meta["stats"].get("visible_lights", 0)), "width": size[0],
         "height": size[1], "technique": tech.name, "role": tech.role, "samples": len(samples)}
    r.update(measure.option_cells(opts))
    timing = measure.timing_cells(samples)
    r.update({k: timing[k] for k in TIMED})
    r.update({f"gpu_{name}_ms": v[0] for name, v in measure.pass_stats(samples).items()})
    r["setup_ms"] = float(sum(res.meta.get("setup_ms", {}).values()))
    fig = measure.figure_cells(res)
    r["evaluated_pp"], r["exact_pp"], r["waste"] = fig["evaluated_pp"], fig["exact_pp"], fig["waste"]
    r["mismatch_pixels"] = int(((res.contrib_count != ref.contrib_count) |
                                (res.contrib_hash != ref.contrib_hash)).sum())
    r["wall_ms"] = wall_ms
    return r


def columns(rows) -> list[str]:
    gpu = list(dict.fromkeys(k for r in rows for k in r if k.startswith("gpu_") and k != "gpu_lighting_ms"))
    return (FIXED + option_columns() + [f"cpu_{s}_ms" for s in STAGES] + gpu + TAIL)


def write(rows: list[dict], out: Path, info: dict) -> None:
    write_csv(rows, out / "path.csv", columns(rows))
    by = {}
    for r in rows:
        by.setdefault(r["technique"], []).append(r)
    summary = {t: {"frames": len(rs),
                   "frame_cost_ms": statistics.median(r["frame_cost_ms"] for r in rs),
                   "gpu_lighting_ms": statistics.median(r["gpu_lighting_ms"] for r in rs),
                   "cpu_total_ms": statistics.median(r["cpu_total_ms"] for r in rs),
                   "evaluated_pp": statistics.median(r["evaluated_pp"] for r in rs),
                   "exact_pp": statistics.median(r["exact_pp"] for r in rs),
                   "mismatch_pixels": sum(r["mismatch_pixels"] for r in rs)} for t, rs in by.items()}
    from .machine import machine_info
    (out / "path.json").write_text(json.dumps(dict(machine_info(), **info, medians=summary),
                                              indent=1, default=str) + "\n")
    plot(by, out / "path.png", info)
    print(f"{'technique':10} {'frames':>6} {'cost ms':>9} {'GPU ms':>9} {'CPU ms':>8} "
          f"{'eval/px':>8} {'exact/px':>8} {'mismatch':>8}")
    for t, s in summary.items():
        print(f"{t:10} {s['frames']:6d} {s['frame_cost_ms']:9.2f} {s['gpu_lighting_ms']:9.2f} "
              f"{s['cpu_total_ms']:8.2f} {s['evaluated_pp']:8.2f} {s['exact_pp']:8.2f} "
              f"{s['mismatch_pixels']:8d}")
    print(f"bench: wrote {out / 'path.csv'} ({len(rows)} rows), path.json, path.png", file=sys.stderr)


def plot(by: dict, path: Path, info: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.6), dpi=100)
    for t, rs in by.items():
        f = [r["frame"] for r in rs]
        axes[0].plot(f, [r["gpu_lighting_ms"] for r in rs], label=t, lw=1.2)
        axes[1].plot(f, [r["evaluated_pp"] for r in rs], label=t, lw=1.2)
    axes[0].set_ylabel("GPU lighting ms (culling + shading)")
    axes[1].set_ylabel("lights evaluated / covered pixel")
    for ax in axes:
        ax.set_xlabel("path frame")
        ax.set_yscale("log")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle(f"{info['scene']} along {Path(info['path']).name}, {info['size'][0]}x{info['size'][1]}, "
                 f"{info['lights']} lights", fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


__all__ = ["path_main", "wants_path", "run_path"]
