"""Live window: the capture pipeline, every frame, in a moderngl-window app with a Dear ImGui
panel (imgui-bundle, through moderngl-window's integration).

    python -m app.window [--scene city] [--technique T] [--view V] [--lights N] [--size WxH]
                         [--exposure auto|X] [--ambient A] [--heat-max N]
                         [--target-fps 10] [--move-scale auto|S]
                         [--record PATH.json | --replay PATH.json] [--inspect XxY]
                         [--frames N] [--screenshot PATH] [--keys "3,v,tile=32"]
                         [--views mono|stereo] [--eye-separation M] [--stereo-way per-view|union]
                         [--transparent-layers L] [--froxels WxHxD] [--froxel-slice K] [--fog-hold on|off]
                         [technique options] [--window pyglet|glfw|headless] [--backend egl]

Start: without --technique, the fastest exact technique for the scene (probe.fastest: every
technique but the reference and the floor, ranked by two frames each at 1/64 of the probe's
pixels, then timed at the window's size, at most 960x540 pixels, in that order within the
budget; one that would refuse the frame, Technique.refusal, is left out unbuilt and named
with its limit; a technique is never named here).  A technique whose frame is predicted
over a second is announced in the HUD before it renders; start-up work over a second has a
console line (progress.py).

Panel (right; F1 hides it, H hides all the UI): the technique and every option it declares
(its Options.specs(): flag, range, help), its views, light count / seed / distribution,
exposure (auto or manual EV), ambient, the heat scale (fixed max, evaluated or exact lights,
overlay on the shaded image), the split view's second technique, inspect, camera path
buttons, and the timers: per GPU pass and CPU stage the rolling median and minimum and a
history graph.  A change applies on the next frame.

Keys: one table, app.window.keys.KEYS, which gives the key names, the HUD's help line, the
panel's key list and the dispatch (1-9 the first nine techniques, T the next one, every one
past the ninth too; the panel's technique list has them all).

Dynamic resolution (scale.py): while the camera moves, the shaded view renders at the scale
that holds --target-fps (or --move-scale), scaled up bilinearly; at rest, in the views that
show statistics, on a screenshot's frame, full size; a reduced frame's figures are the last
full-size frame's (app.py says which frames and why).

Views (views.py): shaded, heat, tiles, slices, classes, diff (pixels whose light set differs
from the reference's), split (two techniques side by side); a technique offers the ones its
`views` attribute names.  A scene adds its own (fog_view.py): layers (lights evaluated over
the opaque surface and its transparent layers) and froxels (a fog scene's froxel light counts,
one depth slice, < > step it).

Two eyes (stereo_view.py, --views stereo or B): both eyes rendered by app.stereo from the fly
camera every frame, each at half the window's width, side by side.  Fog: the window's froxel
grid is coarser than capture's (fog_view.WINDOW_FROXELS) and a frame is held while nothing
it was rendered from changes (compose.py), so that the CPU's froxel sets are not rebuilt.

The window drives the renderer through its public API only: render(readback=False) for the
frame's figures and Build, then its own declared passes (app.window.passes) through
Renderer.run: the frame sums and the exposure histogram (the only per-frame readback, ~560
bytes), the view.  Scripted runs: --frames N exits after N frames and prints one JSON line
per frame and a summary line; --keys replays one step per frame from the first frame;
--screenshot writes the last frame (at --frames N, or on Esc).  `--window headless` renders
to an EGL framebuffer with no display (backend egl by default).

    app.py      the WindowConfig: wires the parts     launch.py   flags, window, main
    keys.py     the key table, --keys steps           compose.py  the frame composer
    figures.py  figures, the UI's model (UIModel)     recorder.py camera path played / recorded
    hud.py      HUD and panel text                    ui.py       imgui HUD, panel, colour bar
    panel.py    the panel's state and controls        (options: app.given_options, app.display)
    views.py    the views' overlays, HUD notes        passes.py   the window's passes, stashes
    camera.py   the fly camera                        (camera path files: scenes.camera_path)
    inspect.py  what is under the cursor              lightsets.py the light draws
    probe.py    start-up probe, frame costs           timers.py   timer history
    progress.py console lines for slow work           variant_view.py the variants view, legend
    scale.py    dynamic resolution's controller      stereo_view.py  two eyes side by side
    fog_view.py fog's grid, froxels and layers views
"""
from .camera import FlyCamera
from .keys import KEY_NAMES, key_names, parse_keys
from .launch import build_parser, main

__all__ = ["KEY_NAMES", "key_names", "parse_keys", "FlyCamera", "main", "build_parser"]
