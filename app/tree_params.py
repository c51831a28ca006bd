"""Tree parameters study: lights per leaf, leaf cap and the approximate depth sort, measured
in hardware-neutral figures (nodes visited and lights evaluated per pixel, nodes stored) and
CPU build time, for every technique that declares those options (`tree`, `hybrid`).

    python -m app.tree_params --scene city --lights 8192 --size 480x270
"""
from __future__ import annotations

from dataclasses import replace
import statistics
import sys

from . import cli

SWEEP = [  # (lights_per_leaf, max_leaves, sort_buckets)
    (1, 64, 0), (2, 64, 0), (4, 64, 0), (6, 64, 0), (8, 64, 0), (16, 64, 0),
    (6, 16, 0), (6, 256, 0), (6, 64, 512), (6, 64, 64),
]
OPTIONS = ("lights_per_leaf", "max_leaves", "sort_buckets")


def main(argv=None) -> None:
    p = cli.Parser(prog="python -m app.tree_params", description=__doc__.splitlines()[0])
    cli.add_scene_args(p)
    p.add_argument("--repeat", type=int, default=5, help="CPU builds per setting (median)")
    args = p.parse_args(argv)
    from cpu_prep.arena import Arena
    from .pipeline.renderer import Renderer
    from .techniques import REGISTRY
    from .techniques.options import all_specs
    scene = cli.load_scene_args(args)
    names = [n for n, t in REGISTRY.items() if set(OPTIONS) <= set(t.Options.names())]
    r = Renderer(scene, args.size)
    try:
        w, h = r.size
        # the rendered frame's camera (path frame 0); a fresh arena reused across the builds
        frame = replace(r.frame_input(0, 64), arena=Arena())
        specs = all_specs(REGISTRY[n].Options for n in names)
        grid = "".join(f", {k} {specs[k].default}" for k in ("tile", "slices") if k in specs)
        print(f"scene {args.scene}, {len(scene.lights)} lights, {w}x{h}{grid}\n")
        print("| technique | lights/leaf | max leaves | sort buckets | nodes | nodes visited/px "
              "| lights evaluated/px | exact/px | build+sort ms |")
        print("|---|---|---|---|---|---|---|---|---|")
        for name in names:
            t = REGISTRY[name]
            for lpl, ml, buckets in SWEEP:
                opts = t.Options.make(dict(zip(OPTIONS, (lpl, ml, buckets))), name)
                res = r.render(t, 0, opts)
                ms = []
                for _ in range(args.repeat):
                    b = t.build(frame, opts)
                    ms.append(b.times.ms.get("build", 0.0) + b.times.ms["sort"])
                lit = res.depth > 0
                print(f"| {name} | {lpl} | {ml} | {buckets or 'exact'} | {res.meta['stats']['nodes']} "
                      f"| {res.nodes[lit].mean():.2f} | {res.evaluated[lit].mean():.2f} "
                      f"| {res.contrib_count[lit].mean():.2f} | {statistics.median(ms):.2f} |")
                sys.stdout.flush()
    finally:
        r.release()


if __name__ == "__main__":
    cli.run_main(lambda: main(sys.argv[1:]))
