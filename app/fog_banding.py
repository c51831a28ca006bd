"""The banding case: a froxel lit from the list of the one cell its centre falls in, as if
that list were its exact set (the shortcut of --froxel-lookup centre), against the exact sets.

    python -m app.fog_banding [--scene hangar-fog] [--technique clustered] [--size 480x270]
                              [--froxels 160x90x64] [--lights N] --out DIR

On a grid of its own (the froxels straddle the technique's cells) a froxel lit at its
octants' centres (8 samples) also reaches lights of its other cells, which the centre cell's
list lacks: the image shows the cells' edges.  On the matched grid (a froxel per cell) the
centre cell holds every light the froxel meets, and the image is the exact one bit for bit.
Writes, per grid, the exact and the shortcut's image and their difference (x10), and prints
each grid's largest difference over the brightest pixel and its share of pixels more than 1%
off.  The lights' radii are scaled down (--radius-scale) so that many end inside a cell.
"""
from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path

import numpy as np

from . import cli
from .pipeline.fog import FogOptions


def fog_only(renderer, technique, fo: FogOptions) -> np.ndarray:
    renderer.fog_options = fo
    return renderer.render(technique, readback=True).image


def banding(scene, technique, size, froxels, radius_scale: float = 1.0) -> dict:
    """{grid: {"exact": image, "centre": image, "error": max |centre - exact| / max exact,
    "pixels_off": the share of pixels more than 1% off}} for `froxels` (WxHxD) and the
    matched grid, both lit at 8 samples a froxel; the scene's lights' radii times
    `radius_scale` (a copy: the scene is left as it was)."""
    from .pipeline.renderer import Renderer
    scene = copy.copy(scene)
    scene.lights = scene.lights.copy()
    scene.lights["radius"] *= np.float32(radius_scale)
    out = {}
    with Renderer(scene, size) as renderer:
        for grid in (froxels, "matched"):
            exact = fog_only(renderer, technique, FogOptions(grid, 8, "exact"))
            centre = fog_only(renderer, technique, FogOptions(grid, 8, "centre"))
            diff = np.abs(centre - exact).max(axis=2)
            err = float(diff.max() / max(float(exact.max()), 1e-30))
            off = float((diff > 0.01 * exact.max(axis=2)).mean())
            name = grid if isinstance(grid, str) else "x".join(map(str, grid))
            out[name] = {"exact": exact, "centre": centre, "error": err, "pixels_off": off}
    return out


def banding_images(r: dict) -> dict[str, np.ndarray]:
    """One grid's images of banding() as shown (uint8, the exact image's exposure): "exact",
    "centre" and "difference" (|centre - exact| x 10)."""
    from . import images
    exposure = images.auto_exposure(r["exact"], np.ones(r["exact"].shape[:2], bool))
    shown = lambda x: images.display(x, None, exposure, 0.0)
    return {"exact": shown(r["exact"]), "centre": shown(r["centre"]),
            "difference": shown(10 * np.abs(r["centre"] - r["exact"]))}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m app.fog_banding", description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="hangar-fog")
    p.add_argument("--technique", default="clustered")
    p.add_argument("--size", type=cli.parse_size, default=(480, 270))
    p.add_argument("--froxels", default="160x90x64")
    p.add_argument("--lights", type=int, default=None)
    p.add_argument("--radius-scale", type=float, default=0.2,
                   help="the lights' radii times this (small lights: more of them end inside a cell)")
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    from PIL import Image
    from scenes import load_scene
    from .fog import parse_froxels
    from .techniques import get
    scene = load_scene(args.scene, lights=args.lights)
    if not 0 < args.radius_scale <= 1:
        raise cli.UserError(f"--radius-scale must be in (0, 1] (got {args.radius_scale})")
    if scene.fog is None:
        raise cli.UserError(f"--scene {args.scene}: the scene has no fog")
    froxels = parse_froxels(args.froxels)
    if froxels == "matched":
        raise cli.UserError("--froxels: a grid of its own (WxHxD): the matched grid is the other half")
    res = banding(scene, get(args.technique), args.size, froxels, args.radius_scale)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {}
    for name, r in res.items():
        for kind, shown in banding_images(r).items():
            Image.fromarray(shown).save(out / f"{name}-{kind}.png")
        summary[name] = {"max_error": round(r["error"], 6), "pixels_off_1pct": round(r["pixels_off"], 4)}
    print(json.dumps({"scene": args.scene, "technique": args.technique, "grids": summary}))


if __name__ == "__main__":
    cli.run_main(lambda: main(sys.argv[1:]))
