"""The live window (app.window), driven as scripted runs in a subprocess: its GL context must
not meet the session's EGL context (tests/conftest.py `gl`), one context per process.

Headless (`--window headless`, EGL) for keys, views, options per technique, overlays and
screenshots; one run under Xvfb with the pyglet window.  A missing xvfb-run fails (CI
installs it: LAB_WITH_XVFB=1 scripts/setup.sh).  The HUD's text, the overlays and the
options per technique are also checked without GL.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
import shutil
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from app.techniques import REGISTRY

ROOT = Path(__file__).resolve().parents[3]
SMALL = ["--scene", "city", "--lights", "32", "--size", "160x90"]
LIT = ["--scene", "city", "--size", "160x90"]        # the default 4096 lights: a lit image
NAMES = list(REGISTRY)


def run(args, prefix=(), timeout=120):
    env = dict(os.environ)
    env.pop("MODERNGL_WINDOW", None)       # it would override --window
    proc = subprocess.run([*prefix, sys.executable, "-m", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)
    return proc


def run_window(args, prefix=(), headless=True):
    cmd = ["app.window"] + (["--window", "headless"] if headless else []) + list(args)
    proc = run(cmd, prefix)
    assert proc.returncode == 0, f"exit {proc.returncode}: {proc.stderr[-2000:]}"
    lines = [json.loads(l) for l in proc.stdout.splitlines() if l.startswith("{")]
    frames = [l for l in lines if "frame" in l]
    summary = [l for l in lines if l.get("exit") == "ok"]
    assert len(summary) == 1, proc.stdout[-2000:]
    return frames, summary[0], proc


def load_rgb(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB")).astype(np.int16)


def test_keys_switch_technique_view_and_lights():
    keys = ["3", "v", "v", "+", "1"]
    frames, summary, _ = run_window(SMALL + ["--frames", "6", "--keys", ",".join(keys)])
    assert [f["frame"] for f in frames] == list(range(6))
    assert [f["key"] for f in frames] == keys + [None]
    assert [f["technique"] for f in frames] == [NAMES[2]] * 4 + [NAMES[0]] * 2
    assert [f["view"] for f in frames] == ["shaded", "heat", "classes", "classes", "classes", "classes"]
    assert [f["lights"] for f in frames] == [32, 32, 32, 64, 64, 64]
    for f in frames:
        assert f["size"] == [160, 90]
        assert f["covered"] > 0 and f["visible_lights"] <= f["lights"]
        assert f["evaluated_per_pixel"] >= f["exact_per_pixel"] >= 0
        assert "shade" in f["gpu_ms"] and f["cpu_ms"]
    assert summary["frames"] == 6 and summary["window"] == "headless"
    assert [s[1:3] for s in summary["sequence"]] == [
        [NAMES[2], "shaded"], [NAMES[2], "heat"], [NAMES[2], "classes"], [NAMES[2], "classes"],
        [NAMES[0], "classes"]]


def test_views_cycle_and_moves():
    keys = ["v"] * 5 + ["w", "d", "p"]
    frames, _, _ = run_window(SMALL + ["--frames", "10", "--keys", ",".join(keys)])
    views = [f["view"] for f in frames]
    assert views[:6] == ["heat", "classes", "tiles", "slices", "shaded", "shaded"]
    cams = [f["camera"] for f in frames]
    assert cams[5] != cams[4] and cams[6] != cams[5]          # W, D fly
    assert frames[7]["playing"] and frames[9]["path_frame"] > frames[7]["path_frame"]


def test_screenshot_is_the_scene_and_matches_capture(tmp_path):
    shot, ref = tmp_path / "window.png", tmp_path / "capture.png"
    _, summary, _ = run_window(LIT + ["--technique", "hybrid", "--frames", "2", "--no-hud",
                                      "--screenshot", str(shot)])
    assert summary["screenshots"] == [str(shot)]
    img = load_rgb(shot)
    assert img.shape == (90, 160, 3)
    assert img.var() > 0 and (img.max(2) > 0).mean() > 0.05      # lit, not blank
    # the shaded view is capture's tone-mapped image (same camera at frame 0, same tonemap)
    proc = run(["app.capture", *LIT, "--technique", "hybrid", "--out", str(ref)])
    assert proc.returncode == 0, proc.stderr
    diff = np.abs(img - load_rgb(ref))
    assert diff.max() <= 2 and (diff > 0).mean() < 0.01, (diff.max(), (diff > 0).mean())


def test_k_screenshot_and_heat_view(tmp_path):
    # K on frame 0 saves the shaded view into --shot-dir; V; the last frame (heat) --screenshot
    b = tmp_path / "heat.png"
    _, summary, _ = run_window(LIT + ["--frames", "2", "--no-hud", "--keys", "k,v",
                                      "--shot-dir", str(tmp_path / "shots"), "--screenshot", str(b)])
    shots = summary["screenshots"]
    assert len(shots) == 2 and Path(shots[0]).parent == tmp_path / "shots" and shots[1] == str(b)
    assert "shaded" in Path(shots[0]).name
    sa, sb = load_rgb(shots[0]), load_rgb(b)
    assert sa.shape == sb.shape == (90, 160, 3)
    assert sb.var() > 0 and np.abs(sa - sb).mean() > 1


def test_hud_drawn_on_screenshot(tmp_path):
    a, b = tmp_path / "plain.png", tmp_path / "hud.png"
    run_window(["--scene", "city", "--lights", "32", "--size", "320x180", "--frames", "1",
                "--no-hud", "--screenshot", str(a)])
    run_window(["--scene", "city", "--lights", "32", "--size", "320x180", "--frames", "1",
                "--screenshot", str(b)])
    diff = np.abs(load_rgb(a) - load_rgb(b)).sum(2)
    ys, xs = np.nonzero(diff)
    assert len(ys) > 100 and ys.min() < 10 and xs.min() < 10     # text in the top-left corner


@pytest.mark.parametrize("args", [["--frames", "0"], ["--keys", "3,nope"], ["--size", "12"],
                                  ["--technique", "nope"], ["--no-such-flag"],
                                  ["--window", "nope"], ["--heat-max", "-1"],
                                  ["--technique", "brute", "--tile", "32"],
                                  ["--tile", "32"],                 # the default start: brute
                                  ["--technique", "tree", "--slices", "8"],
                                  ["--technique", "tree", "--tile", "7000"]])
def test_bad_flags_one_line_exit_2(args):
    proc = run(["app.window", "--window", "headless", *args])
    assert proc.returncode == 2
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:"), proc.stderr
    assert "Traceback" not in proc.stderr


def test_pyglet_window_under_xvfb(tmp_path):
    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        pytest.fail("xvfb-run not found: install xvfb (LAB_WITH_XVFB=1 scripts/setup.sh)")
    shot = tmp_path / "xvfb.png"
    frames, summary, _ = run_window(
        LIT + ["--window", "pyglet", "--frames", "3", "--keys", "5,v,v,v,v", "--no-hud",
               "--screenshot", str(shot)],
        prefix=[xvfb, "-a", "-s", "-screen 0 640x480x24"], headless=False)
    assert summary["window"] == "pyglet" and summary["frames"] == 3
    assert [(f["technique"], f["view"]) for f in frames] == [(NAMES[4], "shaded"), (NAMES[4], "heat"),
                                                            (NAMES[4], "classes")]
    img = load_rgb(shot)
    assert img.shape == (90, 160, 3) and img.var() > 0


def key_of(name: str) -> str:
    """The digit key that selects a technique (REGISTRY order)."""
    return str(NAMES.index(name) + 1)


def test_options_per_technique():
    # tree starts with both flags; brute takes neither (ignored, named), clustered takes
    # --tile only, hybrid both; the grid each frame reports is the technique's own
    keys = ["h", key_of("brute"), key_of("clustered"), key_of("hybrid")]
    frames, _, _ = run_window(SMALL + ["--technique", "tree", "--tile", "32", "--lights-per-leaf", "2",
                                       "--frames", "4", "--keys", ",".join(keys)])
    tree, brute, clustered, hybrid = frames
    assert tree["technique"] == "tree" and tree["ignored_options"] == []
    assert tree["options"]["tile"] == 32 and tree["options"]["lights_per_leaf"] == 2
    assert tree["grid"] == {"tile": 32, "tiles": [5, 3], "slices": 1}
    assert brute["technique"] == "brute" and brute["options"] == {}
    assert brute["ignored_options"] == ["lights_per_leaf", "tile"] and brute["grid"] is None
    assert clustered["options"]["tile"] == 32 and clustered["ignored_options"] == ["lights_per_leaf"]
    assert clustered["grid"]["tile"] == 32 and clustered["grid"]["slices"] > 1
    assert hybrid["options"]["tile"] == 32 and hybrid["options"]["lights_per_leaf"] == 2
    assert hybrid["ignored_options"] == []


def test_perfect_is_a_view_too():
    # the floor technique runs its untimed set-up (count, plan, fill) through the window
    frames, _, _ = run_window(LIT + ["--frames", "2", "--keys", key_of("perfect")])
    for f in frames:
        assert f["technique"] == "perfect" and f["grid"] is None
        assert f["exact_per_pixel"] > 0 and f["evaluated_per_pixel"] == f["exact_per_pixel"]
        assert f["setup_ms"] and "shade" in f["gpu_ms"]


def overlay_shots(tmp_path, technique, options=("--tile", "32")):
    """Shaded, tiles and slices views of one frame (K on frames 0, 4 and 6)."""
    frames, summary, _ = run_window(SMALL + ["--technique", technique, *options, "--no-hud",
                                             "--frames", "7", "--keys", "k,v,v,v,k,v,k",
                                             "--shot-dir", str(tmp_path / technique)])
    assert [f["view"] for f in frames[::2]] == ["shaded", "classes", "tiles", "slices"]
    shots = summary["screenshots"]
    assert [Path(s).name.split("-")[3] for s in shots] == ["shaded", "tiles", "slices"]
    return [load_rgb(s) for s in shots]


def test_tiles_overlay_is_the_techniques_grid(tmp_path):
    shaded, tiles, slices = overlay_shots(tmp_path, "tree")
    diff = np.abs(tiles - shaded).sum(2) > 0
    rows, cols = np.nonzero(diff)
    h = shaded.shape[0]
    on_line = ((h - 1 - rows) % 32 == 0) | (cols % 32 == 0)   # tiles start at the bottom left
    assert diff.sum() > 100 and on_line.all()
    assert {0, 32, 64, 96, 128} <= set(cols.tolist())
    assert (slices == shaded).all()               # tree has no depth slices: nothing drawn


def test_slices_overlay_of_a_2_5d_grid(tmp_path):
    shaded, tiles, slices = overlay_shots(tmp_path, "hybrid")
    assert (np.abs(tiles - shaded).sum(2) > 0).sum() > 100
    assert (np.abs(slices - shaded).sum(2) > 0).mean() > 0.3


def test_no_overlay_for_a_technique_without_a_grid(tmp_path):
    shaded, tiles, slices = overlay_shots(tmp_path, "brute", options=())
    assert (tiles == shaded).all() and (slices == shaded).all()


# ---- no GL: key names and the fly camera --------------------------------------------------

def test_key_names_and_parse():
    from app.window import KEY_NAMES, key_names, parse_keys

    class Keys:
        NUMBER_1, NUMBER_9, W, V, F12, ESCAPE, K = 49, 57, 119, 118, 300, 27, 107
        NUMPAD_1 = "undefined"
    m = key_names(Keys)
    assert m == {49: "1", 57: "9", 119: "w", 118: "v", 300: "f12", 27: "escape", 107: "k"}
    assert parse_keys(" 3, V ,f12") == ["3", "v", "f12"]
    assert set("123456789") <= set(KEY_NAMES)


def test_fly_camera():
    from app.window import FlyCamera
    from scenes.model import Camera
    cam = Camera((0.0, 5.0, 30.0), (0.0, 12.0, -500.0), (0.0, 1.0, 0.0), 60.0, 0.5, 3000.0)
    fly = FlyCamera(cam)
    assert fly.camera() is cam                        # unmoved: the scene camera exactly
    f = np.array(fly.forward())
    want = np.subtract(cam.target, cam.position)
    assert np.allclose(f, want / np.linalg.norm(want), atol=1e-6)
    fly.move(10.0, 0.0, 0.0)
    moved = fly.camera()
    assert np.allclose(np.subtract(moved.position, cam.position), 10 * f, atol=1e-4)
    fly.turn(math.pi / 2, 0.0)                        # quarter turn right: looks along +x
    f2 = np.array(fly.forward())
    assert f2[0] > 0.99 and abs(f2[2]) < 0.2


def test_hud_text_names_missing_overlays_and_ignored_options():
    from types import SimpleNamespace
    from app.window.hud import hud_lines
    from app.window.options import WindowOptions
    from app.window.views import Overlay, view_note
    none = Overlay.of(None)
    assert view_note("tiles", "brute", none, 1).startswith("no tiles for brute")
    assert view_note("slices", "perfect", none, 1).startswith("no depth slices for perfect")
    grid = SimpleNamespace(tile=32, tiles_x=5, tiles_y=3, slices=1, slice_scale=0.0, slice_bias=0.0)
    tiles = Overlay.of(grid)
    assert view_note("tiles", "tree", tiles, 1) == "tiles: 32 px, 5x3 (tree's grid)"
    assert view_note("slices", "tree", tiles, 1).startswith("no depth slices for tree: 2D tiles")
    assert view_note("shaded", "tree", tiles, 1) is None

    opts = WindowOptions({"tile": 32, "lights_per_leaf": 2})
    tree, ignored = opts.for_technique(REGISTRY["tree"])
    assert type(tree) is REGISTRY["tree"].Options and tree.tile == 32 and ignored == ()
    brute, ignored = opts.for_technique(REGISTRY["brute"])
    assert brute.as_dict() == {} and ignored == ("lights_per_leaf", "tile")
    assert opts.hud_line(REGISTRY["tree"]) == "options: --tile 32  --lights-per-leaf 2"
    line = opts.hud_line(REGISTRY["brute"])
    assert line == "options: defaults   (not taken by brute: --tile 32  --lights-per-leaf 2)"
    assert WindowOptions({}).hud_line(REGISTRY["hybrid"]) == "options: defaults"

    f = {"technique": "brute", "view": "tiles", "size": [160, 90], "lights": 32, "visible_lights": 31,
         "evaluated_per_pixel": 31.0, "exact_per_pixel": 0.5, "cpu_ms": {"cull": 1.0},
         "gpu_ms": {"shade": 2.0}, "setup_ms": {}}
    lines = hud_lines(f, position="1/6", role="reference", software=True, playing=False,
                      options=line, note=view_note("tiles", "brute", none, 1))
    assert lines[0].startswith("brute [reference] (1/6)   view: tiles")
    assert line in lines and any(l.startswith("no tiles for brute") for l in lines)
