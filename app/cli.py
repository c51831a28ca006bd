"""Shared command-line pieces: one-line argument errors, WxH sizes, scene arguments, and the
technique options, whose flags come from the techniques' own declarations."""
from __future__ import annotations

import argparse
import sys

from .errors import UserError, exit_with


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


def bounded(kind, lo, hi):
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
    p.add_argument("--lights", type=bounded(int, 0, 4_194_304), help="light count (default: the scene's)")
    p.add_argument("--seed", type=bounded(int, 0, 2**31 - 1), default=0, help="light draw seed")
    p.add_argument("--distribution", choices=("uniform", "geometry"),
                   help="builtin scenes: lights in the bounding box or on geometry")
    p.add_argument("--size", type=parse_size, help="WxH (default: the scene's resolution)")


def _option_type(spec):
    def parse(text):
        try:
            # a choice takes its name or its number (spec.check knows both)
            return spec.check(text if spec.choices else spec.kind(text))
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {spec.kind.__name__}, got '{text}'") from None
        except UserError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return parse


def add_option_args(p: argparse.ArgumentParser) -> None:
    """Every option of every registered technique, once, as declared; a flag not given
    stays absent from the namespace (the technique's default applies)."""
    from .techniques import REGISTRY
    from .techniques.options import all_specs
    specs = all_specs(t.Options for t in REGISTRY.values())
    owners = {n: [t.name for t in REGISTRY.values() if n in t.Options.names()] for n in specs}
    g = p.add_argument_group("technique options (an option the technique does not take is an error)")
    for name, s in specs.items():
        who = f" [{', '.join(owners[name])}; default {s.label(s.default) if s.choices else s.default}]"
        if s.kind is bool:
            g.add_argument(s.flag, dest=name, action=argparse.BooleanOptionalAction,
                           default=argparse.SUPPRESS, help=s.help + who)
        else:
            g.add_argument(s.flag, dest=name, type=_option_type(s), default=argparse.SUPPRESS,
                           metavar="NAME|K" if s.choices else s.kind.__name__.upper(),
                           help=s.help + who)


def given_options(args) -> dict:
    """{option name: value} of the technique flags given on the command line."""
    from .techniques import REGISTRY
    from .techniques.options import all_specs
    return {n: getattr(args, n) for n in all_specs(t.Options for t in REGISTRY.values())
            if hasattr(args, n)}


def options_for(technique, args):
    """The technique's Options from the flags given; one it does not take is an error."""
    return technique.Options.make(given_options(args), technique.name)


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
