"""`python -m app.bench cpu`: the CPU stage of one technique alone, with no GL context at
all (nothing here imports moderngl; a test checks it).

    technique.build R times after a warm-up (numba JIT): median/min/max ms of each stage
    (cull, sort, bin, build, pack) and of the total, and the build's structure sizes
    (visible lights, cells, list entries, tree nodes).

    --sweep 8192,16384,32768,65536   the same for each light count in turn: one table row
                                     (or, with --json, one object in "rows") a count, and
                                     the growth of the total from the first to the last
    --growth [--threads 1,2] [--out DIR]
                                     every technique with a CPU build (a
                                     bin or build step; --technique a,b to choose) at each
                                     count of --sweep (default 8,192 doubling to 1,048,576)
                                     on each thread count, interleaved; the time per
                                     doubling and each build buffer's bytes; --out writes
                                     growth.csv (results.csv's schema, study "growth"),
                                     cpu_growth.png and growth.md (the report's CPU page)
    --c-reference                    hybrid (or clustered) against the plain
                                     single-threaded C reference of its CPU stage (point
                                     lights; app.bench.c_reference), the two interleaved on
                                     the same frame (numba on --threads, default 1): per step
                                     and in total min / median of each, the ratio numba / C
    --lean-reference                 with --c-reference's two, a third interleaved: the lean C
                                     written from the tree paper alone (lean_ref.c), ratio
                                     numba / lean, and its per-cell light sets against ours

The machine is shared (2 cores, other work on them): compare minimums and medians over
many builds (--repeat 31 or more), never single runs.  docs/cpu_stage.md has the profile.
"""
from __future__ import annotations

from dataclasses import dataclass
import json
import sys
from typing import Callable

from cpu_prep.arena import Arena

from .. import cli
from ..errors import UserError
from ..pipeline.passes import FrameInput
from ..results import CPU_STAGES, UPLOAD, stats
from ..techniques import REGISTRY, get
from .args import int_list
from .study import CountSeries, Study

GROWTH_LIGHTS = tuple(8192 << k for k in range(8))  # 8,192 .. 1,048,576, doubling


def cpu_stage_samples(technique, scene, size, opts, repeat: int, frame: int = 0,
                      frames: int = 64, lights=None,
                      upload: Callable | None = None, warmup: int = 1) -> dict:
    """technique.build `repeat` times (after `warmup` unrecorded builds) on the scene's camera
    at `frame`: per-stage lists of ms (every stage of CPU_STAGES, 0 where a technique has
    none), 'total', the visible light count, the build's sizes (SIZE_STATS) and the bytes
    of each of its buffers ('bytes').  `upload(build) -> ms` adds an upload stage."""
    from cpu_prep.camera import frame_camera
    w, h = size
    cam = frame_camera(scene.camera_at(frame, frames), w, h)
    lights = scene.lights if lights is None else lights
    opts = technique.resolve_options(opts)
    # one arena across the repeats: the frame-to-frame reuse an engine (and the Renderer) has
    fi = FrameInput(lights, cam, scene.max_depth or cam.far, Arena())
    for _ in range(warmup):
        technique.build(fi, opts)
    out = new_samples(upload is not None)
    for _ in range(repeat):
        record(out, technique.build(fi, opts), upload)
    return out


def new_samples(upload: bool = False) -> dict:
    """cpu_stage_samples' result before any build: empty lists of ms per stage."""
    out = {k: [] for k in list(CPU_STAGES) + ([UPLOAD] if upload else []) + ["total"]}
    out.update(visible=0, sizes={}, bytes={})
    return out


def record(out: dict, b, upload: Callable | None = None) -> None:
    """Add one build's stage times (and its upload's), visible count, sizes and buffer
    bytes to `out` (new_samples)."""
    ms = dict(b.times.ms)
    if upload:
        ms[UPLOAD] = upload(b)
    for k, v in out.items():
        if isinstance(v, list) and k != "total":
            v.append(float(ms.get(k, 0.0)))
    out["total"].append(float(sum(ms.values())))
    out["visible"] = int(b.stats.get("visible_lights", 0))
    out["sizes"] = {k: int(v) for k, v in b.stats.items() if k in SIZE_STATS}
    out["bytes"] = {k: int(a.nbytes) for k, a in b.buffers.items()}


# the build statistics worth printing beside the times (app.techniques: Build.stats)
SIZE_STATS = ("cells", "list_entries", "nodes", "trees", "lists", "bit_tile_used")

GROWTH = "growth"                                  # results.csv study of the growth series


def cache_bytes() -> dict[str, int]:
    """{"L1d", "L2", "L3": bytes} of cpu0's data caches, from sysfs (what it lacks, absent)."""
    from pathlib import Path
    out = {}
    for d in sorted(Path("/sys/devices/system/cpu/cpu0/cache").glob("index*")):
        try:
            kind, level = (d / "type").read_text().strip(), (d / "level").read_text().strip()
            size = (d / "size").read_text().strip()
        except OSError:
            continue
        if kind in ("Data", "Unified") and size[:-1].isdigit():
            unit = {"K": 1 << 10, "M": 1 << 20}.get(size[-1], 1)
            out["L1d" if level == "1" else f"L{level}"] = int(size[:-1]) * unit
    return out


def growth_row(technique, scene_name: str, n: int, size, frames: int, opts, s: dict,
               threads: int) -> dict:
    """One results.csv row of the growth series from cpu_stage_samples' result `s`: stage
    medians, the total's median / min / max, the build buffers' bytes (bytes_lights, the
    light rows; bytes_culling, the rest), and in `stats` (JSON) the thread count, every
    buffer's bytes, the build's sizes and this machine's cache sizes."""
    from .measure import option_cells
    r = {"study": GROWTH, "scene": scene_name, "lights": n, "visible": s["visible"],
         "width": size[0], "height": size[1], "frame": 0, "frames": frames,
         "technique": technique.name, "role": technique.role, "cutoff": 0,
         "samples": len(s["total"])}
    r.update(option_cells(opts))
    for k in CPU_STAGES:
        r[f"cpu_{k}_ms"] = stats(s[k])[0]
    r["cpu_total_ms"], r["cpu_total_min_ms"], r["cpu_total_max_ms"] = stats(s["total"])
    r["bytes_lights"] = int(s["bytes"].get("lights", 0))
    r["bytes_culling"] = int(sum(v for k, v in s["bytes"].items() if k != "lights"))
    r["stats"] = json.dumps({"threads": int(threads), "buffer_bytes": s["bytes"],
                             "caches": cache_bytes(), **s["sizes"]}, sort_keys=True)
    return r


def growth_series(scene_name: str, counts, threads, size, repeat: int, techniques=None,
                  opts: dict | None = None, seed: int = 0, frames: int = 64,
                  cap_ms: float = 0.0, progress: Callable | None = None) -> list[dict]:
    """The growth series: the CPU stage of each technique (`techniques`, default: every one
    with a CPU build, a bin or build step, found in the warm-up) at each light count of the
    builtin scene on each thread count of `threads`, one growth_row each.  A warm-up round
    builds every configuration once; then `repeat` rounds build each once more, counts,
    thread counts and techniques interleaved, so a change of the shared machine's load
    falls on all of them alike (not on one count, where it would pass for a change of
    slope).  One arena per technique, reused across counts (as frames of changing counts
    reuse it).  `cap_ms`: a technique whose warm-up build passes it runs no larger count
    on that thread count (the quick preset's bound on its time); `opts`: {technique:
    options}.  numba's thread count is restored."""
    from cpu_prep.camera import frame_camera
    from scenes import BUILTIN_SCENES, load_scene
    if scene_name not in BUILTIN_SCENES or not counts or not threads:
        return []
    before = set_cpu_threads(0)
    names = list(techniques or REGISTRY)
    techs = {n: get(n) for n in names}
    o = {n: techs[n].resolve_options((opts or {}).get(n)) for n in names}
    arenas = {n: Arena() for n in names}
    inputs, samples, used, dropped, capped = {}, {}, {}, set(), set()
    total, i = (repeat + 1) * len(counts) * len(threads) * len(names), 0
    try:
        for rnd in range(repeat + 1):
            for n in counts:
                if rnd == 0:
                    scene = load_scene(scene_name, lights=int(n), seed=seed)
                    cam = frame_camera(scene.camera_at(0, frames), *size)
                    for m in names:
                        inputs[m, n] = FrameInput(scene.lights, cam, scene.max_depth or cam.far,
                                                  arenas[m])
                for t in threads:
                    used[t] = set_cpu_threads(t)
                    for name in names:
                        i += 1
                        if name in dropped or (name, t) in capped and (name, n, t) not in samples:
                            continue
                        if progress:
                            progress(i, total, f"{GROWTH} {scene_name} {n} lights {name} on "
                                               f"{used[t]} thread(s) at {size[0]}x{size[1]}"
                                               + (" (warm-up)" if rnd == 0 else ""))
                        b = techs[name].build(inputs[name, n], o[name])
                        if rnd > 0:
                            record(samples[name, n, t], b)
                        elif techniques is None and not (b.times.ms.get("bin") or b.times.ms.get("build")):
                            dropped.add(name)
                        else:
                            samples[name, n, t] = new_samples()
                            if cap_ms and sum(b.times.ms.values()) > cap_ms:
                                capped.add((name, t))
    finally:
        set_cpu_threads(before)
    return [growth_row(techs[name], scene_name, int(n), size, frames, o[name], s, used[t])
            for (name, n, t), s in samples.items() if name not in dropped]


@dataclass(frozen=True)
class GrowthConfig(CountSeries):
    """The CPU stage's growth: every technique with a CPU build, each count on each of
    `threads` in turn (lights (): none); cap_ms: a technique whose median build passes it
    runs no larger count (0: no cap); seed and frames: the sweep's (Shared)."""
    threads: tuple[int, ...]
    cap_ms: float
    seed: int
    frames: int


class GrowthStudy(Study):
    """The sweep's growth series: results.csv rows of study "growth" (the report's CPU page)."""
    name = GROWTH
    sections = ("cpu",)
    Config = GrowthConfig

    def run(self, out, sweep) -> list[dict]:
        c = self.config
        return growth_series(c.scene, c.lights, c.threads, c.size, c.repeat, seed=c.seed,
                             frames=c.frames, cap_ms=c.cap_ms, progress=sweep.progress)


def set_cpu_threads(n: int) -> int:
    """Run the CPU stage's numba kernels on n threads (0: leave numba's default); returns
    the count in use."""
    import numba
    if n > 0:
        numba.set_num_threads(min(int(n), numba.config.NUMBA_NUM_THREADS))
    return int(numba.get_num_threads())


DESCRIPTION = "CPU stage of one technique, no GL context"


def cpu_main(argv) -> None:
    """`bench cpu ARGV` (the command's one parser: app.bench.main)."""
    from . import main
    main(["cpu", *argv])


def run(args) -> None:
    """`bench cpu`; a build past a buffer limit (cpu_prep.limits.LimitError, e.g. a light
    index list over the storage-block limit) is one line, as the other user errors."""
    from cpu_prep.limits import LimitError
    try:
        _run(args)
    except LimitError as exc:
        raise UserError(str(exc)) from None


def add_args(p) -> None:
    """The `cpu` subcommand's flags."""
    cli.add_scene_args(p)
    p.add_argument("--technique", default=None,
                   help="technique id (default hybrid; with --growth a list a,b, default every "
                        "technique with a CPU build)")
    p.add_argument("--frame", type=int, default=0, help="camera path frame (of --frames)")
    p.add_argument("--frames", type=int, default=64, help="length of the camera path loop")
    p.add_argument("--repeat", type=int, default=9, help="measured builds (after one warm-up)")
    p.add_argument("--threads", default=None,
                   help="numba threads of the CPU stage (default 1, as the paper; 0: all); "
                        "with --growth a list, default 1,2")
    p.add_argument("--sweep", metavar="N,N,...",
                   help="light counts to run in turn (instead of --lights): one row each")
    p.add_argument("--growth", action="store_true",
                   help="the growth series: techniques x counts x threads")
    p.add_argument("--out", help="--growth: folder for growth.csv, cpu_growth.png, growth.md")
    p.add_argument("--c-reference", action="store_true",
                   help="hybrid or clustered against the plain single-threaded C reference of "
                        "its CPU stage (point lights only), interleaved, with the ratio numba / C")
    p.add_argument("--lean-reference", action="store_true",
                   help="with the C reference, the lean C of the tree paper's design "
                        "(lean_ref.c, point lights) interleaved as a third, ratio numba / lean")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    cli.add_option_args(p)


def _run(args) -> None:
    if args.repeat < 1 or args.frames < 1 or args.frame < 0:
        raise UserError("--repeat and --frames must be >= 1, --frame >= 0")
    threads = int_list(args.threads, "--threads") if args.threads else ((1, 2) if args.growth else (1,))
    args.c_reference = args.c_reference or args.lean_reference
    if args.c_reference and (args.growth or args.sweep):
        raise UserError(f"--{'lean' if args.lean_reference else 'c'}-reference: one light count "
                        f"(no --sweep or --growth)")
    if args.growth:
        _growth_main(args, threads)
        return
    if args.out:
        raise UserError("--out: only with --growth")
    if len(threads) != 1:
        raise UserError("--threads: one count (a list only with --growth)")
    technique = get(args.technique or "hybrid")
    opts = cli.options_for(technique, args)
    if args.c_reference:
        from .c_reference.compare import main as c_reference_main
        c_reference_main(args, threads, technique, opts)
        return
    threads = set_cpu_threads(threads[0])
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


def _growth_main(args, threads) -> None:
    from pathlib import Path
    names = [n.strip() for n in args.technique.split(",") if n.strip()] if args.technique else None
    techs = [get(n) for n in names] if names else None      # unknown ids: one line
    opts = {t.name: cli.options_for(t, args) for t in techs} if techs and len(techs) == 1 else None
    counts = int_list(args.sweep, "--sweep") if args.sweep else GROWTH_LIGHTS
    from scenes import BUILTIN_SCENES, load_scene
    if args.scene not in BUILTIN_SCENES:
        raise UserError(f"--growth: --scene must be a builtin scene ({', '.join(BUILTIN_SCENES)}; "
                        f"got '{args.scene}')")
    size = tuple(args.size or load_scene(args.scene, lights=0).resolution)
    log = (lambda i, total, what: sys.stderr.write(f"[{i}/{total}] {what}\n")) if not args.json else None
    rows = growth_series(args.scene, counts, threads, size, args.repeat, names, opts,
                         args.seed, args.frames, progress=log)
    if not rows:
        raise UserError(f"--growth: no technique with a CPU build on '{args.scene}' (a builtin scene)")
    from ..report.cpu import growth_report
    if args.out:
        from ..results import columns, write_csv
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        write_csv(rows, out / "growth.csv", columns())
        png, text, tables = growth_report(rows, out)
        (out / "growth.md").write_text(
            "# CPU stage growth\n\n" + (f"![CPU stage growth]({png})\n\n" if png else "")
            + "\n".join(t if t.startswith(("|", "-")) else f"- {t}" for t in text)
            + "\n\n" + tables + "\n")
    if args.json:
        print(json.dumps({"rows": rows}))
        return
    _, text, tables = growth_report(rows, None)
    print(tables)
    print("\n".join(text))


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
