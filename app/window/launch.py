"""The command line of `python -m app.window`: its flags, the window it opens (pyglet,
glfw, or headless EGL), the run, and the summary line of a run."""
from __future__ import annotations

import argparse
import json
import math
import os
import time

from .. import cli
from ..errors import UserError
from .keys import parse_keys
from .views import VIEWS

DESCRIPTION = "Live window: the capture pipeline, every frame, in a moderngl-window app."


def _positive(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got '{text}'") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    return v


def build_parser():
    import moderngl_window as mglw
    # moderngl-window's own flags (--window, --backend, --fullscreen, --vsync, --resizable,
    # --hidden, --samples, --cursor, --size_mult); our --size (WxH) replaces its --size.
    p = cli.Parser(prog="python -m app.window", description=DESCRIPTION,
                   parents=[mglw.create_parser()], conflict_handler="resolve")
    cli.add_scene_args(p)
    p.add_argument("--technique", default=None, help="starting technique id (default: the first)")
    p.add_argument("--view", choices=VIEWS, default="shaded", help="starting view")
    p.add_argument("--frames", type=_positive, help="exit after N frames (scripted run)")
    p.add_argument("--screenshot", help="PNG of the last frame")
    p.add_argument("--keys", type=parse_keys, default=[], help='key names replayed one per frame, e.g. "3,v,v"')
    p.add_argument("--path", action="store_true", help="start playing the camera path")
    p.add_argument("--path-frames", type=_positive, default=600,
                   help="frames of one camera-path loop (capture --frame K --frames F = path frame K of F)")
    p.add_argument("--heat-max", type=float, default=0.0,
                   help="heat view: lights per pixel at the top of the ramp (0: the frame's max)")
    p.add_argument("--no-hud", action="store_true", help="start with the HUD hidden")
    p.add_argument("--json", action="store_true", help="print a JSON line per frame (default with --frames)")
    p.add_argument("--shot-dir", default=".", help="folder of K/F12 screenshots")
    cli.add_option_args(p)
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
                     samples=args.samples or 0, cursor=True if args.cursor is None else args.cursor,
                     backend=backend)
    except Exception as exc:
        raise UserError(f"could not open a {name} window with OpenGL 4.3 "
                        f"({' '.join(str(exc).split())[:160]}){no_display}") from None
    if window.ctx.version_code < 430:
        raise UserError(f"the {name} window's context is OpenGL {window.ctx.version_code}, 430 needed")
    mglw.activate_context(window=window)
    return window, name


def main(argv=None) -> None:
    args = build_parser().parse_args(argv)
    from scenes import BUILTIN_SCENES
    from ..techniques import REGISTRY, get
    technique = get(args.technique) if args.technique else next(iter(REGISTRY.values()))
    if not (args.heat_max >= 0 and math.isfinite(args.heat_max)):
        raise UserError(f"--heat-max must be >= 0 (got {args.heat_max})")
    cli.options_for(technique, args)     # the starting technique takes every flag given
    scene = cli.load_scene_args(args)
    size = args.size or tuple(scene.resolution)

    import weakref
    import moderngl_window as mglw
    from moderngl_window.timers.clock import Timer
    window, name = open_window(args, size)
    from .app import LabWindow
    setup = {"args": args, "scene": scene, "technique": technique.name,
             "given": cli.given_options(args), "builtin": args.scene in BUILTIN_SCENES}
    app = LabWindow(setup, ctx=window.ctx, wnd=window, timer=Timer())
    # as moderngl_window.create_window_config_instance does: the window's events go to
    # the config its __init__ wired up (the `config` setter would wire them again)
    window._config = weakref.ref(app)
    window.swap_buffers()
    window.set_default_viewport()
    t0 = time.perf_counter()
    mglw.run_window_config_instance(app)
    # the states the run went through: [first frame, technique, view, lights, [w, h]] per change
    sequence = []
    for i, h in enumerate(app.history):
        state = [h["technique"], h["view"], h["lights"], h["size"]]
        if not sequence or sequence[-1][1:] != state:
            sequence.append([i] + state)
    print(json.dumps({"exit": "ok", "window": name, "frames": app.frame,
                      "wall_s": round(time.perf_counter() - t0, 2), "sequence": sequence,
                      "size": list(app.renderer.size), "screenshots": app.shots,
                      "renderer": app.renderer.limits.renderer}), flush=True)
