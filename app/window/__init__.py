"""Live window: the capture pipeline, every frame, in a moderngl-window app.

    python -m app.window [--scene city] [--technique hybrid] [--view shaded] [--lights N]
                         [--size WxH] [--window pyglet|glfw|headless] [--backend egl]
                         [--frames N] [--screenshot PATH] [--keys "3,v,v"] [technique options]

Keys: 1..9 technique (REGISTRY order), V next view (shaded, heat, classes, tiles, slices),
W/A/S/D fly (Q/E down/up, Shift faster, scroll wheel changes speed), drag the mouse to look,
P play/stop the scene's camera path, R reset the camera, + / - (or ] / [) double / halve the
light count, K or F12 screenshot, H hide the HUD, Esc quit.

Technique options (--tile, --slices, ...): the starting technique must take every flag given
(as in capture); a technique switched to with a key takes the ones it declares, and the HUD
names the ones it ignores.  The tiles and slices views draw the technique's own grid (its
Build's), and say so when it has none.

The window drives the renderer through its public API only: render(readback=False) for the
frame's figures and Build, then its own declared passes (app.window.passes) through
Renderer.run: the frame sums (32 bytes, the only per-frame readback), the view, the HUD.
Scripted runs: --frames N exits after N frames and prints one JSON line per frame and a
summary line; --keys replays key names, one per frame, from the first frame; --screenshot
writes the last frame (at --frames N, or on Esc).  `--window headless` renders to an EGL
framebuffer with no display (backend egl by default).

    keys.py     key names (--keys and the handler)      camera.py   the fly camera
    views.py    the views and their overlays            options.py  options per technique
    passes.py   the window's passes                     hud.py      HUD text and texture
    app.py      the WindowConfig                        launch.py   flags, window, main
"""
from .camera import FlyCamera
from .keys import KEY_NAMES, key_names, parse_keys
from .launch import build_parser, main

__all__ = ["KEY_NAMES", "key_names", "parse_keys", "FlyCamera", "main", "build_parser"]
