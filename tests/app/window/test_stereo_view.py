"""Two eyes in the window (app.window.stereo_view): both eyes side by side, each the image
capture writes for that eye; B back to mono; the refusals in one line.  The window runs in
a subprocess (tests/app/window/test_window.py says why), under Xvfb with the pyglet window
for the side-by-side run."""
from __future__ import annotations

import shutil

import numpy as np
import pytest

from app.techniques import REGISTRY

from tests.app.window.window_run import load_rgb, run, run_window

# a fixed exposure: the window shows both eyes at one (the left eye's auto one by default),
# capture exposes each eye by its own histogram
EYES = ["--scene", "city", "--size", "160x90", "--technique", "clustered", "--eye-separation", "3",
        "--exposure", "4"]


def xvfb_prefix():
    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        pytest.fail("xvfb-run not found: install xvfb (LAB_WITH_XVFB=1 scripts/setup.sh)")
    return [xvfb, "-a", "-s", "-screen 0 640x480x24"]


def test_both_eyes_side_by_side_are_captures_eyes_and_b_goes_mono(tmp_path):
    shots = tmp_path / "shots"
    frames, summary, _ = run_window(
        EYES + ["--views", "stereo", "--window", "pyglet", "--no-hud", "--frames", "2",
                "--keys", "k,b", "--shot-dir", str(shots)], prefix=xvfb_prefix(), headless=False)
    st = frames[0]["stereo"]
    assert summary["window"] == "pyglet"
    assert st["way"] == "per-view" and st["separation"] == 3.0 and st["eye_size"] == [80, 90]
    assert frames[0]["render_size"] == [80, 90] and frames[0]["size"] == [160, 90]
    left, right = st["eyes"]["left"], st["eyes"]["right"]
    # the frame's ms are both eyes' summed
    assert sum(frames[0]["gpu_ms"].values()) == pytest.approx(left["gpu_ms"] + right["gpu_ms"], abs=0.01)
    assert frames[1]["stereo"] is None and frames[1]["render_size"] == [160, 90]     # B: mono
    img = load_rgb(summary["screenshots"][0])
    assert img.shape == (90, 160, 3)
    halves = img[:, :80], img[:, 80:]
    assert np.abs(halves[0] - halves[1]).mean() > 2                 # the two eyes differ
    # the union way: one CPU stage for both eyes, the same eyes (exact in each)
    union, _, _ = run_window(EYES + ["--views", "stereo", "--stereo-way", "union", "--no-hud",
                                     "--frames", "1", "--screenshot", str(tmp_path / "union.png")])
    su = union[0]["stereo"]
    assert su["way"] == "union" and su["share"] == REGISTRY["clustered"].stereo_union
    assert su["shared_cpu_ms"] and "cull" in su["shared_cpu_ms"]
    assert su["eyes"]["left"]["exact_per_pixel"] == left["exact_per_pixel"]
    unioned = load_rgb(tmp_path / "union.png")
    # each half is capture's image of that eye (capture's eye is the whole --size)
    proc = run(["app.capture", *EYES, "--size", "80x90", "--views", "stereo", "--out", str(tmp_path / "f.png")])
    assert proc.returncode == 0, proc.stderr
    for half, other, eye in zip(halves, (unioned[:, :80], unioned[:, 80:]), ("left", "right")):
        want = load_rgb(tmp_path / f"f-{eye}.png")
        assert want.shape == (90, 80, 3)
        for got in (half, other):
            diff = np.abs(got - want)
            assert diff.max() <= 2 and (diff > 0).mean() < 0.01, (eye, diff.max(), (diff > 0).mean())


def test_stereo_hud_lines():
    from app.window.hud import stereo_lines
    eye = {"visible_lights": 9, "evaluated_per_pixel": 2.5, "exact_per_pixel": 1.25, "cpu_ms": 1.0, "gpu_ms": 4.0}
    lines = stereo_lines({"way": "union", "separation": 0.064, "share": "structure", "eye_size": [80, 90],
                          "shared_cpu_ms": {"cull": 1.5, "bin": 0.5}, "eyes": {"left": eye, "right": eye}})
    assert lines[0].startswith("stereo union, eyes 0.064 m apart, each 80x90 (B: mono)")
    assert "shared CPU stage (structure) 2.0 ms" in lines[0]
    assert lines[1].startswith("left: visible 9   evaluated/px 2.50") and lines[2].startswith("right:")
    assert stereo_lines(None) == []


@pytest.mark.parametrize("args, words", [
    (["--views", "trio"], "invalid choice: 'trio'"),
    (["--scene", "hangar-fog", "--technique", "clustered", "--views", "stereo", "--stereo-way", "union"],
     "a fog scene's froxels"),
])
def test_stereo_refusals_one_line_exit_2(args, words):
    proc = run(["app.window", "--window", "headless", "--size", "32x18", *args])
    err = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(err) == 1 and words in err[0], proc.stderr
