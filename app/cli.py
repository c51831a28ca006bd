"""Shared command-line pieces: one-line argument errors, WxH sizes, technique options."""
from __future__ import annotations

import argparse
import sys

from .errors import UserError, exit_with
from .techniques import Options


class Parser(argparse.ArgumentParser):
    """argparse that reports a bad flag in one line (exit status 2), no usage dump."""

    def error(self, message):
        exit_with(f"{self.prog}: {message}")


def parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must be WxH, e.g. 960x540 (got '{text}')") from None
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise argparse.ArgumentTypeError(f"size {w}x{h} is outside 1..16384")
    return w, h


def _bounded(kind, lo, hi):
    def parse(text):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got '{text}'") from None
        if not (lo <= v <= hi) or v != v:
            raise argparse.ArgumentTypeError(f"{v} is outside {lo}..{hi}")
        return v
    return parse


def add_scene_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scene", default="city", help="builtin scene name or a scene JSON file")
    p.add_argument("--lights", type=_bounded(int, 0, 4_194_304), help="light count (default: the scene's)")
    p.add_argument("--seed", type=_bounded(int, 0, 2**31 - 1), default=0, help="light draw seed")
    p.add_argument("--distribution", choices=("uniform", "geometry"),
                   help="builtin scenes: lights in the bounding box or on geometry")
    p.add_argument("--size", type=parse_size, help="WxH (default: the scene's resolution)")


def add_option_args(p: argparse.ArgumentParser) -> None:
    d = Options()
    p.add_argument("--tile", type=_bounded(int, 4, 256), default=d.tile, help="tile size in pixels")
    p.add_argument("--slices", type=_bounded(int, 2, 64), default=d.slices, help="depth slices")
    p.add_argument("--lights-per-leaf", type=_bounded(int, 1, 4096), default=d.lights_per_leaf)
    p.add_argument("--max-leaves", type=_bounded(int, 1, 4096), default=d.max_leaves,
                   help="power of two")
    p.add_argument("--sort-buckets", type=_bounded(int, 0, 32768), default=d.sort_buckets,
                   help="0 exact depth sort, else approximate bucket sort")
    p.add_argument("--radius-scale", type=_bounded(float, 1e-3, 1e3), default=d.radius_scale,
                   help="hybrid heuristic: cell.radius = scale x half the cell depth")
    p.add_argument("--duplicated", action="store_true", help="lists hold copies of the lights")
    p.add_argument("--native-wave", action="store_true", help="use native subgroup ops if present")


def options_from(args) -> Options:
    if args.max_leaves & (args.max_leaves - 1):
        raise UserError(f"--max-leaves must be a power of two (got {args.max_leaves})")
    return Options(tile=args.tile, slices=args.slices, lights_per_leaf=args.lights_per_leaf,
                   max_leaves=args.max_leaves, sort_buckets=args.sort_buckets,
                   radius_scale=args.radius_scale, duplicated=args.duplicated,
                   native_wave=args.native_wave)


def load_scene_args(args):
    from scenes import load_scene
    return load_scene(args.scene, lights=args.lights, seed=args.seed, distribution=args.distribution)


def run_main(main) -> None:
    """Run `main()`, turning user errors into one line and exit status 2."""
    from scenes import SceneError
    try:
        main()
    except (UserError, SceneError) as exc:
        exit_with(str(exc))
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        raise SystemExit(130)
