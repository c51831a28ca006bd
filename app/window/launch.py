"""The command line of `python -m app.window`: its flags (the lab's first, then the window
system's), the window it opens (pyglet, glfw, or headless EGL), the run, and the summary
line of a run."""
from __future__ import annotations

import argparse
import json
import os
import time

from .. import cli
from ..display import DISPLAY
from ..errors import UserError
from ..views import ALL_VIEWS, views_of, with_view
from . import progress
from .keys import parse_keys
from .views import WINDOW_VIEWS
from .scale import MIN_SCALE

DESCRIPTION = ("Live window: the capture pipeline, every frame, with a panel of every option "
               "(Dear ImGui). Starts on the fastest exact technique for the scene.")
WINDOW_TYPES = ("pyglet", "glfw", "headless", "sdl2", "pyside2", "pyqt5", "pygame2", "tk")


def _positive(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got '{text}'") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    return v


def _bool(text: str) -> bool:
    t = text.lower()
    if t in ("1", "true", "yes", "on"):
        return True
    if t in ("0", "false", "no", "off"):
        return False
    raise argparse.ArgumentTypeError(f"expected true or false, got '{text}'")


def _point(text: str) -> str:
    try:
        x, y = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected XxY window pixels, e.g. 80x45 (got '{text}')") from None
    if x < 0 or y < 0:
        raise argparse.ArgumentTypeError(f"expected XxY >= 0 (got '{text}')")
    return f"{x}x{y}"


def _move_scale(text: str):
    """--move-scale: 'auto' (None: held by --target-fps) or a scale in MIN_SCALE..1."""
    if text == "auto":
        return None
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'auto' or a scale, got '{text}'") from None
    if not MIN_SCALE <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"expected 'auto' or a scale in {MIN_SCALE:g}..1, got {v:g}")
    return v


def add_scale_args(p) -> None:
    """--target-fps, --move-scale: dynamic resolution while the camera moves (app.window.scale)."""
    s = DISPLAY["target_fps"]
    p.add_argument(s.flag, type=cli._option_type(s), default=s.default,
                   help=f"{s.help}; {s.lo:g}..{s.hi:g}, default {s.default:g} (the panel's "
                        f"'target fps')".replace("%", "%%"))
    p.add_argument("--move-scale", type=_move_scale, default=None,
                   help="'auto' (the default: the scale --target-fps holds) or the scale every "
                        f"moving frame takes, {MIN_SCALE:g}..1 (1: always full size)")


def add_feature_args(p) -> None:
    """Two eyes (app.stereo), transparent layers and fog: capture's flags, the window's
    defaults (a coarser froxel grid: fog_view.WINDOW_FROXELS)."""
    from .. import fog, stereo
    from ..pipeline import transparent
    from .fog_view import WINDOW_FROXELS
    g = p.add_argument_group("views (app.stereo)")
    g.add_argument("--views", choices=stereo.VIEWS, default="mono",
                   help="mono: one frame (default); stereo: both eyes every frame, side by side, "
                        "each at half the window's width (B toggles)")
    g.add_argument("--eye-separation", type=float, default=None, metavar="M",
                   help=f"--views stereo: metres between the eyes (default {stereo.DEFAULT_SEPARATION})")
    g.add_argument("--stereo-way", choices=stereo.WAYS, default=None,
                   help="--views stereo: per-view (the structure built per eye, default) or union "
                        "(one CPU stage over both frusta; docs/usage.md)")
    transparent.add_args(p)
    fog.add_fog_args(p)
    w, h, d = WINDOW_FROXELS
    for a in p._actions:
        if "--froxels" in a.option_strings:
            a.help = (f"froxel grid, depth exponential from near to fog.far (the window's default "
                      f"{w}x{h}x{d}, coarser than capture's: the sets are built every frame; W and "
                      f"H at most the render's pixels; 'matched': a froxel per cell of the "
                      f"technique's own grid)")
    p.add_argument("--froxel-slice", type=int, default=0, metavar="K",
                   help="the froxels view's starting depth slice (0 the nearest; < > step it)")
    p.add_argument("--fog-hold", type=_bool, default=True, metavar="on|off",
                   help="a fog scene: while the camera, lights and settings rest, show the last "
                        "frame again instead of rebuilding its froxel sets (default on)")


def check_features(args, scene, candidates, given) -> tuple[dict, list[str]]:
    """The features' settings of a command line ({views, way, separation, fog}) and the
    candidates that can render them; one line and exit 2 for what cannot be."""
    from .. import fog, stereo, stereo_capture
    from ..techniques import REGISTRY
    from .fog_view import refuse_view
    from .stereo_view import refusal
    fo = fog.fog_options(args, scene)               # a scene without fog refuses its flags
    if args.froxel_slice < 0:
        raise UserError(f"--froxel-slice {args.froxel_slice}: expected a slice, 0 or more")
    refuse_view(args.view, scene)                  # froxels, layers: the scene's features
    on = stereo_capture.wanted(args)                # a stereo flag without --views stereo: refused
    way = args.stereo_way or "per-view"
    sep = stereo.check_separation(stereo.DEFAULT_SEPARATION if args.eye_separation is None
                                  else args.eye_separation)
    if on:
        why = {n: refusal(scene, REGISTRY[n], REGISTRY[n].Options.make(given, n), way) for n in candidates}
        ok = [n for n in candidates if why[n] is None]
        if not ok:
            raise UserError(next(iter(why.values())))
        candidates = ok
    return {"stereo": on, "way": way, "separation": sep, "fog": fo}, candidates


def build_parser():
    from ..techniques import REGISTRY
    from .panel import panel_keys
    p = cli.Parser(prog="python -m app.window", description=DESCRIPTION)
    cli.add_scene_args(p)
    p.add_argument("--technique", default=None,
                   help="starting technique id (default: the fastest exact one for the scene, "
                        "measured at start-up)")
    p.add_argument("--reprobe", action="store_true",
                   help="measure the techniques again at start-up (without --technique the window "
                        "starts on the one the last probe found fastest for this scene and size)")
    p.add_argument("--view", choices=ALL_VIEWS + tuple(WINDOW_VIEWS), default="shaded",
                   help="starting view (one the technique has; froxels: a fog scene's, layers: "
                        "a scene's with transparent surfaces)")
    cli.add_display_args(p)
    add_scale_args(p)
    p.add_argument("--frames", type=_positive, help="exit after N frames (scripted run)")
    p.add_argument("--screenshot", help="PNG of the last frame")
    p.add_argument("--keys", type=lambda t: parse_keys(t, panel_keys(REGISTRY)), default=[],
                   help='one step per frame: key names, panel changes NAME=VALUE or clicks '
                        'click:NAME, e.g. "3,v,tile=32,click:duplicated"')
    p.add_argument("--record", metavar="PATH.json", help="record the camera path from the first "
                   "frame (C stops and saves; saved on exit)")
    p.add_argument("--replay", metavar="PATH.json", help="play a recorded camera path, one key a "
                   "frame (P stops / resumes)")
    p.add_argument("--path", action="store_true", help="start playing the scene's camera path")
    cli.add_motion_arg(p)
    p.add_argument("--path-frames", type=_positive, default=600,
                   help="frames of one scene camera-path loop (capture --frame K --frames F = path frame K of F)")
    p.add_argument("--inspect", metavar="XxY", type=_point, dest="cursor",
                   help="inspect the pixel at window position XxY (from the top left) from the start")
    p.add_argument("--no-hud", action="store_true", help="start with the HUD and panel hidden")
    p.add_argument("--json", action="store_true", help="print a JSON line per frame (default with --frames)")
    p.add_argument("--shot-dir", default=".", help="folder of K/F12 screenshots and unnamed recordings")
    cli.add_option_args(p)
    add_feature_args(p)
    w = p.add_argument_group("window system (moderngl-window)")
    w.add_argument("--window", "-wnd", choices=WINDOW_TYPES, default=None,
                   help="window type (default pyglet; MODERNGL_WINDOW overrides; headless: EGL, no display)")
    w.add_argument("--backend", default=None, help="context backend (headless: egl by default)")
    w.add_argument("--fullscreen", action="store_true", help="open fullscreen")
    w.add_argument("--vsync", type=_bool, default=None, help="vsync on or off")
    w.add_argument("--resizable", type=_bool, default=None, help="window resizable or not")
    w.add_argument("--hidden", action="store_true", help="start the window hidden")
    w.add_argument("--samples", type=int, default=None, help="multisampling samples of the window")
    w.add_argument("--mouse-cursor", type=_bool, default=None, dest="mouse_cursor",
                   help="show the mouse cursor or not")
    w.add_argument("--size-mult", type=float, default=1.0, dest="size_mult",
                   help="window size multiplier (the render follows the window)")
    return p


def open_window(args, size):
    """A moderngl-window window of the type asked for (MODERNGL_WINDOW overrides --window)
    with an OpenGL 4.3 context, activated; (window, type name)."""
    import moderngl_window as mglw
    name = os.environ.get("MODERNGL_WINDOW") or args.window or "pyglet"
    backend = args.backend or ("egl" if name == "headless" else None)
    no_display = ("; there is no display: use --window headless, or run under xvfb-run -a"
                  if name != "headless" and not os.environ.get("DISPLAY")
                  and not os.environ.get("WAYLAND_DISPLAY") else "")
    try:
        cls = mglw.get_local_window_cls(name)
    except Exception as exc:
        raise UserError(f"window type '{name}' is not available "
                        f"({' '.join(str(exc).split())[:120]}){no_display}") from None
    w, h = int(size[0] * args.size_mult), int(size[1] * args.size_mult)
    try:
        window = cls(title="many-light lab", size=(w, h), fullscreen=bool(args.fullscreen),
                     resizable=True if args.resizable is None else args.resizable,
                     visible=not args.hidden, gl_version=(4, 3),
                     vsync=True if args.vsync is None else args.vsync,
                     samples=args.samples or 0,
                     cursor=True if args.mouse_cursor is None else args.mouse_cursor,
                     backend=backend)
    except Exception as exc:
        raise UserError(f"could not open a {name} window with OpenGL 4.3 "
                        f"({' '.join(str(exc).split())[:160]}){no_display}") from None
    if window.ctx.version_code < 430:
        raise UserError(f"the {name} window's context is OpenGL {window.ctx.version_code}, 430 needed")
    mglw.activate_context(window=window)
    return window, name


def start_candidates(args, given: dict) -> tuple[str | None, list[str]]:
    """(the starting technique when --technique names it, else None; the techniques the
    start may choose from: every one but the reference and the floor that takes every option
    flag given, together (its Options' own check: --cap-policy hdrp-fptl-24 is fptl's), and
    has the --view asked for).  One line and exit status 2 when none can."""
    from ..techniques import REGISTRY, get
    if args.technique:
        t = get(args.technique)
        cli.options_for(t, args)                     # the starting technique takes every flag given
        if args.view not in views_of(t) + tuple(WINDOW_VIEWS):
            raise UserError(f"--view {args.view}: {t.name} has no {args.view} view (its views: "
                            f"{', '.join(views_of(t))}; techniques with it: "
                            f"{', '.join(with_view(REGISTRY, args.view))})")
        return t.name, [t.name]
    names = set(given)
    plain = [t for t in REGISTRY.values() if t.role == "technique"]
    named = [t for t in plain if names <= set(t.Options.names())
             and args.view in views_of(t) + tuple(WINDOW_VIEWS)]
    refusals = {t.name: _refusal(t, given) for t in named}
    ok = [name for name, why in refusals.items() if why is None]
    if not ok:
        flags = " ".join("--" + n.replace("_", "-") for n in given)
        why = f" ({next(iter(refusals.values()))})" if refusals else ""
        raise UserError(f"no technique takes {flags or 'these options'} and has the {args.view} view"
                        f"{why}: give --technique")
    return None, ok


def _refusal(technique, given: dict) -> str | None:
    """Why `technique`'s Options refuse the given flags together (its own check), or None."""
    try:
        technique.Options.make(given, technique.name)
    except UserError as exc:
        return str(exc)
    return None


def main(argv=None) -> None:
    args = build_parser().parse_args(argv)
    from scenes import BUILTIN_SCENES
    given = cli.given_options(args)
    technique, candidates = start_candidates(args, given)
    with progress.step(f"scene {args.scene}" + (f", {args.lights:,} lights" if args.lights else "")):
        scene = cli.load_scene_args(args)
    if args.replay:
        from scenes.camera_path import load
        load(args.replay)                            # a bad file: one line before any window
    features, candidates = check_features(args, scene, candidates, given)
    size = args.size or tuple(scene.resolution)

    import weakref
    import moderngl_window as mglw
    from moderngl_window.timers.clock import Timer
    window, name = open_window(args, size)
    from .app import LabWindow
    setup = {"args": args, "scene": scene, "technique": technique, "candidates": candidates,
             "given": given, "builtin": args.scene in BUILTIN_SCENES, "features": features}
    t0 = time.perf_counter()
    app = LabWindow(setup, ctx=window.ctx, wnd=window, timer=Timer())
    # as moderngl_window.create_window_config_instance does: the window's events go to
    # the config its __init__ wired up (the `config` setter would wire them again)
    window._config = weakref.ref(app)
    window.swap_buffers()
    window.set_default_viewport()
    mglw.run_window_config_instance(app)
    app.finish()
    # the states the run went through: [first frame, technique, view, lights, [w, h]] per change
    sequence = []
    for i, h in enumerate(app.history):
        state = [h["technique"], h["view"], h["lights"], h["size"]]
        if not sequence or sequence[-1][1:] != state:
            sequence.append([i] + state)
    print(json.dumps({"exit": "ok", "window": name, "frames": app.frame,
                      "wall_s": round(time.perf_counter() - t0, 2), "sequence": sequence,
                      "size": list(app.full_size), "screenshots": app.shots.paths, "screenshot_hud": app.shots.huds,
                      "paths": app.recorder.saved, "started": app.started[0] if app.started else "",
                      "probe_skipped": app.started[1:],
                      "renderer": app.renderer.limits.renderer}), flush=True)
