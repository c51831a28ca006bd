"""Live window: the capture pipeline, every frame, in a moderngl-window app with a Dear ImGui
panel (imgui-bundle, through moderngl-window's integration).

    python -m app.window [--scene city] [--technique T] [--view V] [--lights N] [--size WxH]
                         [--exposure auto|X] [--ambient A] [--heat-max N]
                         [--record PATH.json | --replay PATH.json] [--inspect XxY]
                         [--frames N] [--screenshot PATH] [--keys "3,v,tile=32"]
                         [technique options] [--window pyglet|glfw|headless] [--backend egl]

Start: without --technique, the fastest exact technique for the scene (probe.fastest: every
technique but the reference and the floor, two frames each at the window's size, at most
960x540 pixels; a technique is never named here).  A technique whose frame is predicted over a second is announced in the HUD before it
renders.

Panel (right; F1 hides it, H hides all the UI): the technique and every option it declares
(its Options.specs(): flag, range, help), its views, light count / seed / distribution,
exposure (auto or manual EV), ambient, the heat scale (fixed max, evaluated or exact lights,
overlay on the shaded image), the split view's second technique, inspect, camera path
buttons, and the timers: per GPU pass and CPU stage the rolling median and minimum and a
history graph.  A change applies on the next frame.

Keys: 1..9 technique (REGISTRY order), V next view of the technique, O heat overlay, I
inspect the cursor (its light's bounding sphere, its tile and the tile's light list), W/A/S/D
fly (Q/E down/up, Shift faster, wheel: speed), drag to look, P play/stop the camera path (the
--replay file, else the scene's), C record a camera path / stop and save, R reset the camera,
+ / - (or ] / [) double / halve the light count, K or F12 screenshot, H hide the UI, F1 hide
the panel, Esc quit.

Views (views.py): shaded, heat, tiles, slices, classes, diff (pixels whose light set differs
from the reference's), split (two techniques side by side); a technique offers the ones its
`views` attribute names.

The window drives the renderer through its public API only: render(readback=False) for the
frame's figures and Build, then its own declared passes (app.window.passes) through
Renderer.run: the frame sums and the exposure histogram (the only per-frame readback, ~560
bytes), the view.  Scripted runs: --frames N exits after N frames and prints one JSON line
per frame and a summary line; --keys replays one step per frame from the first frame;
--screenshot writes the last frame (at --frames N, or on Esc).  `--window headless` renders
to an EGL framebuffer with no display (backend egl by default).

    keys.py     key names, --keys steps              camera.py   the fly camera
    views.py    the views, which a technique has     options.py  options per technique
    panel.py    the panel's state and controls       ui.py       the imgui HUD, panel, colour bar
    passes.py   the window's passes, the stashes     probe.py    start-up probe, frame costs
    inspect.py  what is under the cursor             timers.py   timer history
    campath.py  camera path files                    hud.py      HUD text
    app.py      the WindowConfig                     launch.py   flags, window, main
"""
from .camera import FlyCamera
from .keys import KEY_NAMES, key_names, parse_keys
from .launch import build_parser, main

__all__ = ["KEY_NAMES", "key_names", "parse_keys", "FlyCamera", "main", "build_parser"]
