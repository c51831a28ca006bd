"""`python -m app.bench gpu-build`: each technique's structures built on the CPU and on the
GPU (--build cpu / gpu) at each light count, as a ratio, and where the GPU
build's time goes: on llvmpipe the passes run on the same two cores as the numba stage, so
only the ratio (and the passes' shares) mean anything (docs/platform.md "Measuring").

    cpu ms   the CPU stage's steps (cull, sort, bin, build, pack; meta cpu_ms less the upload)
    gpu ms   the build's timed passes (meta gpu_ms: build_cull, build_sort, build_pack,
             build_bin, build_zbin, build_tree); the host steps' readbacks of a count (4 or
             8 bytes, a sync each, setup_ms) are in `readback`, apart

Each figure is the minimum over --repeat samples of one frame (Renderer.render samples), after
one unrecorded frame of each build (numba's and llvmpipe's compilations); the techniques are those whose Options take `build` (app.techniques.gpu_build.BuildOptions).
--out DIR writes DIR/gpu_build.csv (results.csv's schema, study "gpu_build": the CPU build's
stage columns, the GPU build's figures in `stats`) and DIR/gpu_build.md; the report's CPU
page reads gpu_build.csv beside results.csv (app/report/cpu.py gpu_build_report).
"""
from __future__ import annotations

from dataclasses import dataclass
import json
import sys
from pathlib import Path

from .. import cli
from ..errors import UserError
from ..results import CPU_STAGES, stats
from ..techniques import REGISTRY, get
from .args import int_list
from .study import CountSeries, Study

STUDY = "gpu_build"
CSV = "gpu_build.csv"
BUILD_PASSES = ("build_cull", "build_sort", "build_pack", "build_bin", "build_zbin", "build_tree")
READBACKS = ("build_visible", "build_bin_entries", "build_bin_longest", "build_tree_nodes")


def gpu_techniques() -> list[str]:
    """The registry's techniques that take --build."""
    return [t.name for t in REGISTRY.values() if "build" in t.Options.names()]


def _samples(meta: dict) -> list[dict]:
    return meta.get("samples") or [{"cpu_ms": meta["cpu_ms"], "gpu_ms": meta["gpu_ms"]}]


def cpu_build_ms(meta: dict) -> list[float]:
    """Each sample's CPU stage (its steps but the upload)."""
    return [sum(v for k, v in s["cpu_ms"].items() if k != "upload") for s in _samples(meta)]


def gpu_build_ms(meta: dict) -> list[float]:
    """Each sample's GPU build: its timed passes."""
    return [sum(s["gpu_ms"].get(k, 0.0) for k in BUILD_PASSES) for s in _samples(meta)]


def pass_ms(meta: dict) -> dict[str, float]:
    """The fastest sample's ms of each GPU build pass, and the readbacks' (once a frame)."""
    samples = _samples(meta)
    out = {k: min(s["gpu_ms"].get(k, 0.0) for s in samples) for k in BUILD_PASSES}
    out["readback"] = sum(meta["setup_ms"].get(k, 0.0) for k in READBACKS)
    return {k: round(v, 3) for k, v in out.items() if v}


def ratio_row(technique, scene_name: str, n: int, size, cpu, gpu, repeat: int) -> dict:
    """One results.csv row (study "gpu_build") from the CPU-built frame `cpu` and the GPU-built
    `gpu` of one count: the CPU stage's columns (median, min, max), the GPU build's figures
    and their ratio (fastest samples) in `stats`."""
    from .measure import cpu_study_row
    c, g = cpu_build_ms(cpu.meta), gpu_build_ms(gpu.meta)
    per = [dict(s["cpu_ms"]) for s in _samples(cpu.meta)]
    r = cpu_study_row(STUDY, technique, scene_name, n, gpu.meta["stats"].get("visible_lights", 0),
                      size, repeat, technique.resolve_options({}))
    for k in CPU_STAGES:
        r[f"cpu_{k}_ms"] = stats([s.get(k, 0.0) for s in per])[0]
    r["cpu_total_ms"], r["cpu_total_min_ms"], r["cpu_total_max_ms"] = stats(c)
    gmed, gmin, gmax = stats(g)
    r["stats"] = json.dumps({"gpu_build_ms": round(gmed, 3), "gpu_build_min_ms": round(gmin, 3),
                             "gpu_build_max_ms": round(gmax, 3), "passes": pass_ms(gpu.meta),
                             "gpu_over_cpu": round(gmin / min(c), 2) if min(c) > 0 else None},
                            sort_keys=True)
    return r


def ratio_rows(scene_name: str, counts, size, repeat: int, techniques=None, progress=None) -> list[dict]:
    """ratio_row of each technique (default: every one that takes --build) at each count."""
    from scenes import load_scene
    from ..pipeline.renderer import Renderer
    techs = [get(n) for n in (techniques or gpu_techniques())]
    rows, total = [], len(counts) * len(techs)
    with Renderer(load_scene(scene_name, lights=int(counts[0])), size) as r:
        for n in counts:
            r.scene = load_scene(scene_name, lights=int(n))
            for t in techs:
                if progress:
                    progress(len(rows) + 1, total, f"{STUDY} {scene_name} {n} lights {t.name}")
                built = {}
                for b in ("cpu", "gpu"):
                    opts = t.Options.make({"build": b})
                    if n == counts[0]:                 # warm-up: the compilations
                        r.render(t, 0, opts, readback=False)
                    built[b] = r.render(t, 0, opts, samples=repeat, readback=False)
                rows.append(ratio_row(t, scene_name, n, size, built["cpu"], built["gpu"], repeat))
    return rows


@dataclass(frozen=True)
class GpuBuildConfig(CountSeries):
    """The sweep's build comparison (at the rendered size), fastest of `repeat` samples."""


class GpuBuildStudy(Study):
    """The CPU and GPU builds of every technique that takes --build at each count (ratio_rows:
    results.csv study "gpu_build", the report's CPU page); a scene file has no light count
    to set: none."""
    name = STUDY
    sections = ("cpu",)
    Config = GpuBuildConfig

    def run(self, out, sweep) -> list[dict]:
        from scenes import BUILTIN_SCENES
        c = self.config
        if not c.lights or not gpu_techniques():
            return []
        if c.scene not in BUILTIN_SCENES:
            sweep.log.write(f"bench: gpu_build: {c.scene} is a scene file (its own "
                            f"lights, no counts to sweep): skipped\n")
            return []
        return ratio_rows(c.scene, c.lights, c.size, c.repeat, progress=sweep.progress)


DESCRIPTION = "each --build technique's CPU and GPU builds, as a ratio per light count"


def main(argv=None) -> None:
    """`bench gpu-build ARGV` (the command's one parser: app.bench.main)."""
    from . import main as bench_main
    bench_main(["gpu-build", *(sys.argv[1:] if argv is None else argv)])


def add_args(p) -> None:
    """The `gpu-build` subcommand's flags."""
    p.add_argument("--scene", default="city")
    p.add_argument("--sweep", default="8192,32768,131072", help="light counts")
    p.add_argument("--size", type=cli.parse_size, default=(320, 180), help="WxH")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--technique", help="techniques a,b (default: every one that takes --build)")
    p.add_argument("--out", help="folder for gpu_build.csv and gpu_build.md")
    p.add_argument("--json", action="store_true")


def run(args) -> None:
    """`bench gpu-build`: the table (or JSON), and --out's gpu_build.csv and gpu_build.md."""
    if args.repeat < 1:
        raise UserError("--repeat must be >= 1")
    names = [n.strip() for n in args.technique.split(",") if n.strip()] if args.technique else None
    for n in names or ():
        if "build" not in get(n).Options.names():
            raise UserError(f"--technique {n}: it does not take --build (those that do: "
                            f"{', '.join(gpu_techniques())})")
    counts = [n for n in int_list(args.sweep, "--sweep") if n]
    if not counts:
        raise UserError("--sweep: give at least one light count above 0")
    log = (lambda i, total, what: sys.stderr.write(f"[{i}/{total}] {what}\n")) if not args.json else None
    rows = ratio_rows(args.scene, counts, args.size, args.repeat, names, log)
    from ..report.cpu import gpu_build_report
    text, table = gpu_build_report(rows)
    if args.out:
        from ..results import columns, write_csv
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        write_csv(rows, out / CSV, columns())
        (out / "gpu_build.md").write_text("# CPU and GPU builds\n\n" + "\n".join(
            t if t.startswith(("|", "-")) else f"- {t}" for t in text) + "\n\n" + table + "\n")
    if args.json:
        print(json.dumps({"rows": rows}))
        return
    print(table)
    print("\n".join(text))


if __name__ == "__main__":
    cli.run_main(main)
