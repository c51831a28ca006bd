"""Shared command-line pieces: one-line argument errors, WxH sizes, scene arguments (and
the scene they load), the display's flags, --motion, and the technique options, whose
flags come from the techniques' own declarations."""
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


def add_display_args(p) -> None:
    """--exposure, --ambient, --heat-max: the display's options (app.display.DISPLAY, which
    the window's panel reads too), shared by capture and the window."""
    from . import images
    from .display import DISPLAY as d, DISPLAY_FLAGS
    lo_hi = lambda s: f"{s.lo:g}..{s.hi:g}"
    exposure = _option_type(d["exposure"])
    p.add_argument("--exposure", type=lambda t: t if t == "auto" else exposure(t), default="auto",
                   help=f"'auto' (the {images.EXPOSURE_PERCENTILE * 100:.0f}%% luminance of the lit "
                        f"pixels maps to {images.EXPOSURE_TARGET:g}) or a factor on the radiance, "
                        f"{lo_hi(d['exposure'])}")
    for name in (n for n in DISPLAY_FLAGS if n != "exposure"):
        s = d[name]
        p.add_argument(s.flag, type=_option_type(s), default=s.default,
                       help=f"{s.help}; {lo_hi(s)}, default {s.default:g}".replace("%", "%%"))


def add_motion_arg(p) -> None:
    """--motion: the lights' motion (scenes.motion), shared by capture, the window and the bench."""
    from scenes.motion import MOTION_CHOICES
    p.add_argument("--motion", choices=MOTION_CHOICES, default=None,
                   help="the lights' motion along the camera path: 'bounce' (each light at its "
                        "own horizontal velocity, bouncing off the scene's box: scenes.motion), "
                        "'off'; default: the scene's own (a scene file's `motion`; builtins none)")


def load_scene_args(args):
    """The scene of the command line (add_scene_args) with its --motion applied; a command
    line without --motion (no `motion` attribute) keeps the scene's own."""
    from scenes import load_scene
    from scenes.motion import with_motion
    scene = load_scene(args.scene, lights=args.lights, seed=args.seed, distribution=args.distribution)
    return with_motion(scene, getattr(args, "motion", None))


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
