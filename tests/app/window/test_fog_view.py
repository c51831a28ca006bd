"""Fog and transparent layers in the window (app.window.fog_view): a scene with either opens
and shows what capture writes, a fog frame is held while nothing moves, the froxels view is
slice k's froxel_count from capture's dump, and the HUD names the layers and the froxel grid
(the window's coarser default).  The window runs in a subprocess (test_window.py says why)."""
from __future__ import annotations

import numpy as np

from app import images
from app.pipeline.fog import FogOptions
from app.window.fog_view import WINDOW_FROXELS, feature_lines, window_options

from tests.app.window.window_run import load_rgb, run, run_window

FOG = ["--scene", "hangar-fog", "--size", "160x90", "--technique", "clustered", "--froxels", "20x9x8"]


def same_image(a, b) -> None:
    diff = np.abs(a - b)
    assert diff.max() <= 2 and (diff > 0).mean() < 0.01, (diff.max(), (diff > 0).mean())


def test_fog_frame_held_at_rest_and_the_froxels_view_is_captures_slice(tmp_path):
    # K: the shaded frame; F1 (nothing moves: held); > into the froxels view at slice 5, < <
    # to 3, K; W moves: rendered again
    frames, summary, _ = run_window(FOG + ["--froxel-slice", "4", "--no-hud", "--target-fps", "0",
                                           "--frames", "7", "--keys", "k,f1,>,<,<,k,w",
                                           "--shot-dir", str(tmp_path / "shots")])
    assert [f["fog"]["froxels"] for f in frames] == ["20x9x8"] * 7
    assert [f["fog"]["held"] for f in frames] == [None, 0, 0, 0, 0, 0, None]
    assert frames[1]["cpu_ms"] == frames[0]["cpu_ms"] and "froxels" in frames[0]["cpu_ms"]
    assert [f["view"] for f in frames] == ["shaded", "shaded"] + ["froxels"] * 5
    assert [f["froxel_slice"]["k"] for f in frames[2:6]] == [5, 4, 3, 3]
    s, five = frames[5]["froxel_slice"], frames[2]["froxel_slice"]
    assert 0 < s["depth"][0] < s["depth"][1] < five["depth"][0]            # slice 5 lies beyond 3
    shaded, froxels = (load_rgb(p) for p in summary["screenshots"])
    proc = run(["app.capture", *FOG, "--out", str(tmp_path / "f.png"), "--dump", str(tmp_path / "f.npz")])
    assert proc.returncode == 0, proc.stderr
    same_image(shaded, load_rgb(tmp_path / "f.png"))          # the fog, composited as capture's
    counts = np.load(tmp_path / "f.npz")["froxel_count"]       # (D, H, W), row 0 the top
    assert counts.shape == (8, 9, 20) and s["slices"] == 8
    assert s["mean"] == round(float(counts[3].mean()), 4) and s["top"] == max(float(counts.max()), 1.0)
    # each pixel the count of the froxel its centre lies in, on the whole grid's heat scale
    h, w = 90, 160
    cols = ((np.arange(w) + 0.5) * 20 / w).astype(int)
    rows_up = ((np.arange(h) + 0.5) * 9 / h).astype(int)        # from the bottom
    per_pixel = counts[3][::-1][rows_up][::-1][:, cols]        # image rows
    assert len(np.unique(per_pixel)) > 1
    want = images.heat_rgb(per_pixel, np.ones((h, w), bool), s["top"]).astype(np.int16)
    assert np.abs(froxels - want).max() <= 2


def test_transparent_scene_shows_its_layers(tmp_path):
    # K: the shaded frame, composited; then the layers view: lights evaluated over the opaque
    # surface and every layer, per pixel
    common = ["--scene", "city-glass", "--size", "160x90", "--technique", "clustered"]
    frames, summary, _ = run_window(common + ["--frames", "3", "--no-hud", "--keys", "k,view=layers",
                                              "--shot-dir", str(tmp_path / "shots"),
                                              "--screenshot", str(tmp_path / "layers.png")])
    t = frames[0]["transparent"]
    assert t["layers"] >= 1 and t["max_layers"] == 4 and t["gpu_ms"]
    assert frames[0]["fog"] is None and frames[2]["view"] == "layers"
    proc = run(["app.capture", *common, "--out", str(tmp_path / "f.png"), "--dump", str(tmp_path / "f.npz")])
    assert proc.returncode == 0, proc.stderr
    same_image(load_rgb(summary["screenshots"][0]), load_rgb(tmp_path / "f.png"))   # the layers, composited
    d = np.load(tmp_path / "f.npz")
    total = d["evaluated"].astype(np.int64) + d["evaluated_t"].astype(np.int64).sum(0)
    assert (d["evaluated_t"].sum(0) > 0).any() and frames[2]["layers_top"] == float(total.max())
    want = images.heat_rgb(total, np.ones(total.shape, bool), frames[2]["layers_top"]).astype(np.int16)
    assert np.abs(load_rgb(tmp_path / "layers.png") - want).max() <= 2


def test_window_grid_and_hud_lines():
    w, h, d = WINDOW_FROXELS
    assert window_options(None, (960, 540)).froxels == WINDOW_FROXELS
    assert window_options(None, (24, 12)).froxels == (min(w, 24), min(h, 12), d)     # a small frame
    given = FogOptions((200, 100, 16), 8, "exact")
    assert window_options(given, (120, 90)) == FogOptions((120, 90, 16), 8, "exact")
    assert window_options(FogOptions("matched"), (120, 90)).froxels == "matched"
    lines = feature_lines({"transparent": {"layers": 2, "max_layers": 4, "gpu_ms": {"shade": 3.0}},
                           "fog": {"froxels": "40x23x32", "lights_mean": 14.5, "sets_ms": 120.0,
                                   "grid": "window default", "held": 7}})
    assert lines[0].startswith("transparent: 2 layers (of 4)") and "GPU 3.0 ms" in lines[0]
    assert lines[1].startswith("fog 40x23x32 froxels (window default): 14.5 lights a froxel")
    assert "held since frame 7" in lines[1]
    assert feature_lines({}) == []


def test_a_scene_view_the_scene_lacks_is_one_line():
    proc = run(["app.window", "--window", "headless", "--size", "32x18", "--view", "layers"])
    err = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(err) == 1 and "no transparent surfaces" in err[0], proc.stderr


def test_a_technique_that_cannot_serve_froxels_is_refused_in_the_hud():
    # 2 (tiled serves no froxels): said, clustered stays; T: past tiled to the next that
    # serves them; --build gpu through the panel: said, the option stays at its value
    from app.techniques import REGISTRY
    names = list(REGISTRY)
    after = next(n for n in names[names.index("clustered") + 1:] if REGISTRY[n].froxels)
    frames, _, proc = run_window(FOG + ["--frames", "4", "--keys", f"{names.index('tiled') + 1},t,build=gpu"])
    assert [f["technique"] for f in frames] == ["clustered", after, after, after]
    assert all(f["options"].get("build", 0) == 0 for f in frames)
    assert "tiled does not serve froxels" in proc.stderr and "--build with a fog scene" in proc.stderr


def test_fog_in_stereo_each_eye_its_froxels_and_held_at_rest(tmp_path):
    frames, summary, _ = run_window(FOG + ["--views", "stereo", "--eye-separation", "2", "--frames", "3",
                                           "--target-fps", "0", "--no-hud", "--screenshot", str(tmp_path / "s.png")])
    assert [f["fog"]["held"] for f in frames] == [None, 0, 0]
    eyes = frames[0]["stereo"]["eyes"]
    assert frames[0]["stereo"]["eye_size"] == [80, 90] and frames[0]["fog"]["froxels"] == "20x9x8"
    assert eyes["left"]["evaluated_per_pixel"] != eyes["right"]["evaluated_per_pixel"]
    img = load_rgb(tmp_path / "s.png")
    assert np.abs(img[:, :80] - img[:, 80:]).mean() > 1
