"""`python -m app.bench.gpu_build`: clustered's structures built on the CPU and on the GPU
(--build cpu / gpu, issue 23 item 1) at each light count, as a ratio: on llvmpipe the GPU
passes run on the same two cores, so only the ratio means anything (DESIGN "Measuring").

    cpu ms   the CPU stage's steps (cull, sort, bin, pack; meta cpu_ms less the upload)
    gpu ms   the build's passes (build_cull, build_sort, build_bin; meta gpu_ms) plus the
             pack, still a CPU step between them (setup_ms build_pack, run once a frame)

Each figure is the minimum over --repeat samples of one frame (Renderer.render samples).
"""
from __future__ import annotations

import json

from .. import cli
from ..errors import UserError
from ..techniques import REGISTRY
from .presets import int_list

BUILD_PASSES = ("build_cull", "build_sort", "build_bin")


def build_ms(meta: dict, build: str) -> float:
    """The minimum over the samples of one frame's build time (see the module docstring)."""
    samples = meta.get("samples") or [{"cpu_ms": meta["cpu_ms"], "gpu_ms": meta["gpu_ms"]}]
    if build == "cpu":
        return min(sum(v for k, v in s["cpu_ms"].items() if k != "upload") for s in samples)
    pack = meta["setup_ms"].get("build_pack", 0.0)
    return min(sum(s["gpu_ms"].get(k, 0.0) for k in BUILD_PASSES) for s in samples) + pack


def ratio_rows(scene_name: str, counts, size, repeat: int) -> list[dict]:
    from scenes import load_scene
    from ..pipeline.renderer import Renderer
    t = REGISTRY["clustered"]
    rows = []
    with Renderer(load_scene(scene_name, lights=int(counts[0])), size) as r:
        for n in counts:
            r.scene = load_scene(scene_name, lights=int(n))
            row = {"lights": int(n)}
            for build in ("cpu", "gpu"):
                res = r.render(t, 0, t.Options.make({"build": build}), samples=repeat, readback=False)
                row[f"{build}_ms"] = round(build_ms(res.meta, build), 3)
                row["visible"] = res.meta["stats"]["visible_lights"]
            row["gpu_over_cpu"] = round(row["gpu_ms"] / row["cpu_ms"], 2) if row["cpu_ms"] else None
            rows.append(row)
    return rows


def main(argv=None) -> None:
    p = cli.Parser(prog="python -m app.bench.gpu_build",
                   description="clustered's build on the CPU and on the GPU, as a ratio")
    p.add_argument("--scene", default="city")
    p.add_argument("--sweep", default="8192,32768,131072", help="light counts")
    p.add_argument("--size", default="320x180", help="WxH")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    if args.repeat < 1:
        raise UserError("--repeat must be >= 1")
    rows = ratio_rows(args.scene, int_list(args.sweep, "--sweep"), cli.parse_size(args.size), args.repeat)
    if args.json:
        print(json.dumps({"rows": rows}))
        return
    print(f"{'lights':>9} {'visible':>9} {'cpu ms':>9} {'gpu ms':>9} {'gpu/cpu':>8}")
    for r in rows:
        print(f"{r['lights']:9,} {r['visible']:9,} {r['cpu_ms']:9.2f} {r['gpu_ms']:9.2f} {r['gpu_over_cpu']:8}")


if __name__ == "__main__":
    cli.run_main(main)
