"""Tree parameters study: lights per leaf, leaf cap and the approximate depth sort, measured
in hardware-neutral figures (nodes visited and lights evaluated per pixel, nodes stored) and
CPU build time, for `tree` and `hybrid`.

    python -m app.tree_params --scene city --lights 8192 --size 480x270
"""
from __future__ import annotations

import statistics
import sys

from . import cli

SWEEP = [  # (lights_per_leaf, max_leaves, sort_buckets)
    (1, 64, 0), (2, 64, 0), (4, 64, 0), (6, 64, 0), (8, 64, 0), (16, 64, 0),
    (6, 16, 0), (6, 256, 0), (6, 64, 512), (6, 64, 64),
]


def main(argv=None) -> None:
    p = cli.Parser(prog="python -m app.tree_params", description=__doc__.splitlines()[0])
    cli.add_scene_args(p)
    p.add_argument("--repeat", type=int, default=5, help="CPU builds per setting (median)")
    args = p.parse_args(argv)
    from dataclasses import replace
    from cpu_prep.camera import frame_camera
    from .renderer import Renderer
    from .techniques import REGISTRY, FrameInput, Options
    scene = cli.load_scene_args(args)
    r = Renderer(scene, args.size)
    w, h = r.size
    frame = FrameInput(scene.lights, frame_camera(scene.camera, w, h), scene.max_depth or scene.camera.far)
    print(f"scene {args.scene}, {len(scene.lights)} lights, {w}x{h}, tile 48, 16 slices\n")
    print("| technique | lights/leaf | max leaves | sort buckets | nodes | nodes visited/px "
          "| lights evaluated/px | exact/px | build+sort ms |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in ("tree", "hybrid"):
        t = REGISTRY[name]
        for lpl, ml, buckets in SWEEP:
            opts = replace(Options(), lights_per_leaf=lpl, max_leaves=ml, sort_buckets=buckets)
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


if __name__ == "__main__":
    cli.run_main(lambda: main(sys.argv[1:]))
