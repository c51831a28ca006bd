"""The live window (app.window), driven as scripted runs in a subprocess: its GL context must
not meet the session's EGL context (tests/conftest.py `gl`), one context per process.

Headless (`--window headless`, EGL) for keys, views and screenshots; one run under Xvfb with
the pyglet window.  A missing xvfb-run fails (CI installs it: LAB_WITH_XVFB=1 scripts/setup.sh).
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

ROOT = Path(__file__).resolve().parents[2]
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
                                  ["--window", "nope"], ["--heat-max", "-1"]])
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
