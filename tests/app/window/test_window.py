"""The live window (app.window), driven as scripted runs in a subprocess: its GL context must
not meet the session's EGL context (tests/conftest.py `gl`), one context per process.

Headless (`--window headless`, EGL) for keys, views, the panel, options per technique,
overlays, camera paths and screenshots; one run under Xvfb with the pyglet window.  A missing
xvfb-run fails (CI installs it: LAB_WITH_XVFB=1 scripts/setup.sh).  The HUD's text, the
panel's model, the overlays and the options per technique are also checked without GL
(test_panel.py), the present passes in process (test_present.py).
"""
from __future__ import annotations

import json
import math
from pathlib import Path
import shutil

import numpy as np
import pytest

from app.techniques import REGISTRY
from app.views import views_of

from tests.app.window.window_run import LIT, ROOT, SMALL, load_rgb, run, run_window

NAMES = list(REGISTRY)
PLAIN = [t.name for t in REGISTRY.values() if t.role == "technique"]


def key_of(name: str) -> str:
    """The digit key that selects a technique (REGISTRY order)."""
    return str(NAMES.index(name) + 1)


def test_starts_on_the_fastest_exact_technique(tmp_path):
    # no --technique: a probe picks among the plain techniques (never the reference or the
    # floor), says so, and remembers it: the next start takes no probe
    env = {"LAB_CACHE_DIR": str(tmp_path), "LAB_PROBE_BUDGET_S": "300"}
    frames, summary, proc = run_window(SMALL + ["--frames", "2"], env=env)
    assert frames[0]["technique"] in PLAIN
    assert summary["started"].startswith(f"started on {frames[0]['technique']}, the fastest")
    assert all(n in summary["started"] for n in PLAIN) and "probe at 160x90" in summary["started"]
    assert "fastest exact technique" in proc.stderr
    assert (tmp_path / "window-start.json").is_file()
    again, summary, _ = run_window(SMALL + ["--frames", "1"], env=env)
    assert again[0]["technique"] == frames[0]["technique"] and "at the last probe" in summary["started"]


def test_keys_switch_technique_view_and_lights():
    # T: the next technique in registry order (every one, past the ninth too)
    after_brute = NAMES[(NAMES.index("brute") + 1) % len(NAMES)]
    keys = [key_of("clustered"), "v", "v", "+", key_of("brute"), "t"]
    frames, summary, proc = run_window(SMALL + ["--technique", "tree", "--frames", "7",
                                               "--keys", ",".join(keys)])
    assert [f["frame"] for f in frames] == list(range(7))
    assert [f["key"] for f in frames] == keys + [None]
    assert [f["technique"] for f in frames] == ["clustered"] * 4 + ["brute"] + [after_brute] * 2
    # brute has no tiles view: switching to it shows the shaded image and says why
    assert [f["view"] for f in frames] == ["shaded", "heat", "tiles", "tiles", "shaded", "shaded", "shaded"]
    assert "brute has no tiles view" in proc.stderr
    assert [f["lights"] for f in frames] == [32, 32, 32, 64, 64, 64, 64]
    for f in frames:
        assert f["size"] == [160, 90]
        assert f["covered"] > 0 and f["visible_lights"] <= f["lights"]
        assert f["evaluated_per_pixel"] >= f["exact_per_pixel"] >= 0
        assert "shade" in f["gpu_ms"] and f["cpu_ms"]
    assert summary["frames"] == 7 and summary["window"] == "headless"
    assert [s[1:3] for s in summary["sequence"]] == [
        ["clustered", "shaded"], ["clustered", "heat"], ["clustered", "tiles"],
        ["clustered", "tiles"], ["brute", "shaded"], [after_brute, "shaded"]]


def test_views_cycle_through_the_techniques_own_and_moves():
    own = views_of(REGISTRY["hybrid"])
    keys = ["v"] * len(own) + ["w", "d", "p"]
    frames, _, _ = run_window(SMALL + ["--technique", "hybrid", "--frames", str(len(keys) + 2),
                                       "--keys", ",".join(keys)])
    views = [f["view"] for f in frames]
    assert views[:len(own)] == list(own[1:]) + ["shaded"]
    diff = frames[list(own).index("diff") - 1]
    assert diff["view"] == "diff" and diff["differ"] == 0 and diff["reference"] == "brute"
    split = frames[list(own).index("split") - 1]
    assert split["split"]["technique"] in NAMES and split["split"]["technique"] != "hybrid"
    n = len(own)
    cams = [f["camera"] for f in frames]
    assert cams[n] != cams[n - 1] and cams[n + 1] != cams[n]          # W, D fly
    assert frames[n + 2]["playing"] and frames[-1]["path_frame"] > frames[n + 2]["path_frame"]


def test_every_technique_offers_its_own_views_only():
    assert views_of(REGISTRY["brute"]) == ("shaded", "heat", "split")
    assert "slices" not in views_of(REGISTRY["tiled"]) and "slices" not in views_of(REGISTRY["tree"])
    assert "classes" in views_of(REGISTRY["hybrid"]) and "classes" in views_of(REGISTRY["tree"])
    assert "classes" not in views_of(REGISTRY["clustered"])
    for t in REGISTRY.values():
        v = views_of(t)
        assert v[:2] == ("shaded", "heat") and "split" in v
        assert ("tiles" in v) == (t.name not in ("brute", "perfect"))


@pytest.mark.parametrize("args, words", [
    (["--technique", "tiled", "--view", "slices"], "tiled has no slices view"),
    (["--technique", "clustered", "--view", "classes"], "clustered has no classes view"),
])
def test_a_view_a_technique_lacks_is_refused(args, words):
    proc = run(["app.window", "--window", "headless", *args])
    assert proc.returncode == 2 and words in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_panel_change_applies_on_the_next_frame():
    # tile=32 typed into the panel on frame 0: frame 0 rendered already, frame 1 uses it;
    # a value out of range is refused in one line and changes nothing
    frames, _, proc = run_window(SMALL + ["--technique", "clustered", "--frames", "4",
                                          "--keys", "tile=32,tile=7000,slices=8"])
    assert frames[0]["options"]["tile"] == 48 and frames[0]["grid"]["tile"] == 48
    assert frames[1]["options"]["tile"] == 32 and frames[1]["grid"]["tile"] == 32
    assert frames[2]["options"]["tile"] == 32 and "--tile must be in 4..256" in proc.stderr
    assert frames[3]["options"]["slices"] == 8 and frames[3]["grid"]["slices"] == 8


def test_panel_widget_click_through_imgui():
    # a real click (imgui mouse events at the checkbox's place, known once the panel has been
    # drawn): move, press, release on frames 1-3; the change applies on the frame after
    frames, _, _ = run_window(["--scene", "city", "--lights", "32", "--size", "640x360",
                               "--technique", "clustered", "--frames", "6",
                               "--keys", "r,click:duplicated"])
    dup = [f["options"]["duplicated"] for f in frames]
    assert dup[:4] == [False] * 4 and dup[-1] is True


def test_screenshot_is_the_scene_and_matches_capture(tmp_path):
    shot, ref = tmp_path / "window.png", tmp_path / "capture.png"
    _, summary, _ = run_window(LIT + ["--technique", "hybrid", "--frames", "2", "--no-hud",
                                      "--screenshot", str(shot)])
    assert summary["screenshots"] == [str(shot)]
    img = load_rgb(shot)
    assert img.shape == (90, 160, 3)
    assert img.var() > 0 and (img.max(2) > 0).mean() > 0.5      # ambient: geometry is visible
    # the shaded view is capture's displayed image (same camera at frame 0, same exposure,
    # ambient and tone mapping: app.images.display and its GLSL twin)
    proc = run(["app.capture", *LIT, "--technique", "hybrid", "--out", str(ref)])
    assert proc.returncode == 0, proc.stderr
    diff = np.abs(img - load_rgb(ref))
    assert diff.max() <= 2 and (diff > 0).mean() < 0.01, (diff.max(), (diff > 0).mean())


def test_heat_view_is_captures_heat_map(tmp_path):
    shot, heat = tmp_path / "window.png", tmp_path / "heat.png"
    run_window(LIT + ["--technique", "tree", "--view", "heat", "--frames", "1", "--no-hud",
                      "--heat-max", "64", "--screenshot", str(shot)])
    proc = run(["app.capture", *LIT, "--technique", "tree", "--heatmap", str(heat), "--heat-max", "64"])
    assert proc.returncode == 0, proc.stderr
    a, b = load_rgb(shot), load_rgb(heat)
    assert b.shape[0] == 90 and b.shape[1] > 160                     # the image, then its colour bar
    assert np.abs(a - b[:, :160]).max() <= 1


def test_k_screenshot_and_heat_view(tmp_path):
    # K on frame 0 saves the shaded view into --shot-dir; V; the last frame (heat) --screenshot
    b = tmp_path / "heat.png"
    _, summary, _ = run_window(LIT + ["--technique", "clustered", "--frames", "2", "--no-hud",
                                      "--keys", "k,v", "--shot-dir", str(tmp_path / "shots"),
                                      "--screenshot", str(b)])
    shots = summary["screenshots"]
    assert len(shots) == 2 and Path(shots[0]).parent == tmp_path / "shots" and shots[1] == str(b)
    assert "shaded" in Path(shots[0]).name
    sa, sb = load_rgb(shots[0]), load_rgb(b)
    assert sa.shape == sb.shape == (90, 160, 3)
    assert sb.var() > 0 and np.abs(sa - sb).mean() > 1


def test_hud_and_panel_on_screenshot_without_old_messages(tmp_path):
    a, b = tmp_path / "plain.png", tmp_path / "hud.png"
    common = ["--scene", "city", "--lights", "32", "--size", "480x270", "--technique", "clustered"]
    run_window(common + ["--frames", "1", "--no-hud", "--screenshot", str(a)])
    _, summary, _ = run_window(common + ["--frames", "3", "--keys", "k,k",
                                         "--shot-dir", str(tmp_path), "--screenshot", str(b)])
    diff = np.abs(load_rgb(a) - load_rgb(b)).sum(2)
    ys, xs = np.nonzero(diff)
    assert len(ys) > 100 and ys.min() < 10 and xs.min() < 10     # the HUD, top left
    assert xs.max() > 470                                        # the panel, right
    # the second and third screenshots are taken while "screenshot: ..." is on screen: they
    # do not carry it
    huds = summary["screenshot_hud"]
    assert len(huds) == 3 and all(huds)
    assert not any("screenshot:" in line for hud in huds for line in hud)


@pytest.mark.parametrize("args", [["--frames", "0"], ["--keys", "3,nope"], ["--keys", "nope=3"],
                                  ["--size", "12"], ["--technique", "nope"], ["--no-such-flag"],
                                  ["--window", "nope"], ["--heat-max", "-1"], ["--exposure", "-2"],
                                  ["--technique", "brute", "--tile", "32"],
                                  ["--technique", "tree", "--slices", "8"],
                                  ["--technique", "tree", "--tile", "7000"],
                                  ["--replay", "/nonexistent/path.json"],
                                  ["--move-scale", "0.1"], ["--target-fps", "-1"]])
def test_bad_flags_one_line_exit_2(args):
    proc = run(["app.window", "--window", "headless", *args])
    assert proc.returncode == 2
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:"), proc.stderr
    assert "Traceback" not in proc.stderr


def test_help_shows_the_labs_options_first():
    proc = run(["app.window", "--help"])
    assert proc.returncode == 0
    out = proc.stdout
    for flag in ("--scene", "--technique", "--exposure", "--record", "--replay", "--keys"):
        assert out.index(flag) < out.index("--window"), flag
    assert out.index("--fullscreen") > out.index("--tile")


def test_pyglet_window_under_xvfb(tmp_path):
    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        pytest.fail("xvfb-run not found: install xvfb (LAB_WITH_XVFB=1 scripts/setup.sh)")
    shot = tmp_path / "xvfb.png"
    frames, summary, _ = run_window(
        LIT + ["--window", "pyglet", "--technique", "hybrid", "--frames", "3", "--keys",
               "v,v,tile=32", "--screenshot", str(shot)],
        prefix=[xvfb, "-a", "-s", "-screen 0 640x480x24"], headless=False)
    assert summary["window"] == "pyglet" and summary["frames"] == 3
    assert [(f["technique"], f["view"]) for f in frames] == [("hybrid", "heat"), ("hybrid", "tiles"),
                                                            ("hybrid", "tiles")]
    img = load_rgb(shot)
    assert img.shape == (90, 160, 3) and img.var() > 0


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
    assert brute["technique"] == "brute" and brute["options"] == REGISTRY["brute"].Options().as_dict()
    assert brute["ignored_options"] == ["lights_per_leaf", "tile"] and brute["grid"] is None
    assert clustered["options"]["tile"] == 32 and clustered["ignored_options"] == ["lights_per_leaf"]
    assert clustered["grid"]["tile"] == 32 and clustered["grid"]["slices"] > 1
    assert hybrid["options"]["tile"] == 32 and hybrid["options"]["lights_per_leaf"] == 2
    assert hybrid["ignored_options"] == []


def test_perfect_is_a_view_too():
    # the floor technique runs its untimed set-up (count, plan, fill) through the window
    frames, _, _ = run_window(LIT + ["--technique", "clustered", "--frames", "2", "--keys",
                                     key_of("perfect")])
    for f in frames:
        assert f["technique"] == "perfect" and f["grid"] is None
        assert f["exact_per_pixel"] > 0 and f["evaluated_per_pixel"] == f["exact_per_pixel"]
        assert f["setup_ms"] and "shade" in f["gpu_ms"]


def overlay_shots(tmp_path, technique, views, options=("--tile", "32")):
    """Screenshots of `views` of one frame (set through the panel, one a frame)."""
    keys = []
    for v in views:
        keys += [f"view={v}", "k"]
    frames, summary, _ = run_window(SMALL + ["--technique", technique, *options, "--no-hud",
                                             "--frames", str(len(keys) + 1), "--keys", ",".join(keys),
                                             "--shot-dir", str(tmp_path / technique)])
    shots = summary["screenshots"]
    assert [Path(s).name.split("-")[3] for s in shots] == list(views)
    return [load_rgb(s) for s in shots]


def test_tiles_overlay_is_the_techniques_grid(tmp_path):
    shaded, tiles = overlay_shots(tmp_path, "tree", ("shaded", "tiles"))
    diff = np.abs(tiles - shaded).sum(2) > 0
    rows, cols = np.nonzero(diff)
    h = shaded.shape[0]
    on_line = ((h - 1 - rows) % 32 == 0) | (cols % 32 == 0)   # tiles start at the bottom left
    assert diff.sum() > 100 and on_line.all()
    assert {0, 32, 64, 96, 128} <= set(cols.tolist())


def test_slices_overlay_of_a_2_5d_grid(tmp_path):
    shaded, tiles, slices = overlay_shots(tmp_path, "hybrid", ("shaded", "tiles", "slices"))
    assert (np.abs(tiles - shaded).sum(2) > 0).sum() > 100
    assert (np.abs(slices - shaded).sum(2) > 0).mean() > 0.3


def test_inspect_the_cursor_light_and_tile(tmp_path):
    # the tile's list holds every light that affects the pixel (a conservative list), and
    # the picked light's bounding sphere is drawn
    plain, shot = tmp_path / "plain.png", tmp_path / "inspect.png"
    run_window(LIT + ["--technique", "tiled", "--tile", "16", "--frames", "1", "--no-hud",
                      "--screenshot", str(plain)])
    frames, _, _ = run_window(LIT + ["--technique", "tiled", "--tile", "16", "--frames", "1",
                                     "--no-hud", "--inspect", "80x70", "--screenshot", str(shot)])
    ins = frames[0]["inspect"]
    assert ins["pixel"] == [80, 90 - 1 - 70]
    assert ins["tile"] == [80, 16, 96, 32] and ins["tile_index"] == [5, 1]
    assert ins["affecting"], "no light affects the inspected pixel: move it"
    assert ins["tile_lights"] >= len(ins["affecting"]) and ins["evaluated"] >= len(ins["affecting"])
    assert ins["light"] in ins["affecting"] and ins["sphere"][3] > 0
    diff = np.abs(load_rgb(shot) - load_rgb(plain)).sum(2) > 0
    assert diff.sum() > 50


def test_record_replay_and_bench_along_the_path(tmp_path):
    path = tmp_path / "fly.json"
    keys = ["w", "w", "d", "w", "e"]
    rec, summary, _ = run_window(SMALL + ["--technique", "clustered", "--frames", "5",
                                          "--keys", ",".join(keys), "--record", str(path)])
    assert summary["paths"] == [str(path)]
    data = json.loads(path.read_text())
    assert data["scene"] == "city" and len(data["keys"]) == 5
    assert [k["position"] for k in data["keys"]] == [pytest.approx(f["camera"], abs=1e-3) for f in rec]
    rep, _, _ = run_window(SMALL + ["--technique", "tree", "--frames", "5", "--replay", str(path)])
    assert [f["camera"] for f in rep] == [f["camera"] for f in rec]
    assert [f["path_frame"] for f in rep] == [0, 1, 2, 3, 4]


def test_slow_technique_is_announced_before_it_renders():
    # the threshold at 1 ms, so that the frame is slow on any machine (brute at 8,192 lights
    # took about 1.3 s here, and under 1 s on a faster VM)
    proc = run(["app.window", "--window", "headless", "--scene", "city", "--lights", "8192",
                "--size", "160x90", "--technique", "brute", "--frames", "1"],
               env={"LAB_SLOW_FRAME_S": "0.001"})
    assert proc.returncode == 0, proc.stderr
    assert "slow: brute needs about" in proc.stderr
    frame = json.loads([l for l in proc.stdout.splitlines() if l.startswith('{"technique"')][0])
    assert frame["technique"] == "brute"


# ---- no GL: key names and the fly camera --------------------------------------------------

def test_key_names_and_parse():
    from app.window import KEY_NAMES, key_names, parse_keys
    from app.window.panel import panel_keys

    class Keys:
        NUMBER_1, NUMBER_9, W, V, F12, ESCAPE, K = 49, 57, 119, 118, 300, 27, 107
        NUMPAD_1 = "undefined"
    m = key_names(Keys)
    assert m == {49: "1", 57: "9", 119: "w", 118: "v", 300: "f12", 27: "escape", 107: "k"}
    assert parse_keys(" 3, V ,f12") == ["3", "v", "f12"]
    assert parse_keys("tile=32, click:Lights-per-leaf", panel_keys(REGISTRY)) == \
        ["tile=32", "click:lights_per_leaf"]
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


def test_maps_view_shows_the_techniques_own_structure(tmp_path):
    """fptl's coarse and pruned lists per tile (Mikkelsen's figures 2.4-2.6) in the window:
    the maps view, M to the next map; a technique without maps has no maps view."""
    frames, _, _ = run_window(["--scene", "gallery", "--size", "96x54", "--technique", "fptl",
                               "--frames", "3", "--keys", "m,m", "--screenshot", str(tmp_path / "m.png")])
    assert [f["view"] for f in frames] == ["maps"] * 3
    assert [f.get("map") for f in frames] == ["coarse", "pruned", "pruned"]
    img = load_rgb(tmp_path / "m.png")
    assert img.std() > 1.0
    proc = run(["app.window", "--window", "headless", "--scene", "gallery", "--size", "32x18",
                "--technique", "brute", "--view", "maps", "--frames", "1"])
    assert proc.returncode == 2 and "maps" in proc.stderr


def test_hud_shows_the_modelled_gpu_time():
    """A scripted run models its first still frame: the HUD gives every named GPU's modelled
    lighting ms (app.model) beside the measured llvmpipe ms."""
    from app.model import cost
    frames, summary, _ = run_window(SMALL + ["--technique", "hybrid", "--frames", "2"])
    line = next(l for l in summary["screenshot_hud"][0] if l.startswith("modelled GPU ms")) \
        if summary.get("screenshot_hud") else frames[-1]["model"]
    assert f"(v{cost.MODEL_VERSION})" in line
    values = {g.key: float(line.split(f"{g.key} ")[1].split()[0]) for g in cost.GPUS}
    assert all(v > 0 for v in values.values()), line
    assert values["h200"] < values["ps4"], line          # 10x the ALUs and 27x the bandwidth


def test_moving_frames_render_reduced_and_statistics_come_from_full_size(tmp_path):
    """Dynamic resolution under Xvfb: the scene's path plays from the first frame (the camera
    moves every frame); F1 (no HUD: nothing changes) thrice, K, P stops, a frame at rest.
    Moving frames render at --move-scale 0.5 and carry the last full-size frame's figures;
    the first frame, the screenshot's and the one at rest render at full size.  A run with
    dynamic resolution off, every frame full size, gives the same screenshot and figures."""
    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        pytest.fail("xvfb-run not found: install xvfb (LAB_WITH_XVFB=1 scripts/setup.sh)")
    common = LIT + ["--technique", "hybrid", "--path", "--no-hud", "--keys", "f1,f1,f1,k,p",
                    "--window", "pyglet"]
    pyglet = {"prefix": [xvfb, "-a", "-s", "-screen 0 640x480x24"], "headless": False}
    frames, summary, _ = run_window(common + ["--move-scale", "0.5", "--frames", "6",
                                              "--shot-dir", str(tmp_path / "a")], **pyglet)
    assert [f["scale"] for f in frames] == [1.0, 0.5, 0.5, 1.0, 0.5, 1.0]
    assert [f["render_size"] for f in frames] == [[160, 90], [80, 45], [80, 45], [160, 90], [80, 45], [160, 90]]
    assert all(f["size"] == [160, 90] for f in frames) and summary["size"] == [160, 90]
    assert [f["stats_frame"] for f in frames] == [0, 0, 0, 3, 3, 5]
    stats = ("evaluated_per_pixel", "exact_per_pixel", "visible_lights", "covered", "gpu_ms")
    for f in frames:
        assert {k: f[k] for k in stats} == {k: frames[f["stats_frame"]][k] for k in stats}
    assert frames[1]["camera"] != frames[0]["camera"] and frames[5]["camera"] == frames[4]["camera"]
    full, _, _ = run_window(common + ["--target-fps", "0", "--frames", "4", "--shot-dir", str(tmp_path / "b")],
                            **pyglet)
    assert [f["scale"] for f in full] == [1.0] * 4 and full[3]["camera"] == frames[3]["camera"]
    assert full[0]["evaluated_per_pixel"] == frames[1]["evaluated_per_pixel"]      # frame 0's
    assert full[1]["evaluated_per_pixel"] != frames[1]["evaluated_per_pixel"]
    assert {k: full[3][k] for k in stats[:-1]} == {k: frames[3][k] for k in stats[:-1]}
    shot, = list((tmp_path / "a").glob("*.png"))
    ref, = list((tmp_path / "b").glob("*.png"))
    diff = np.abs(load_rgb(shot) - load_rgb(ref))
    assert diff.max() <= 2 and (diff > 0).mean() < 0.01, (diff.max(), (diff > 0).mean())


def test_esc_on_a_reduced_frame_saves_a_full_size_one(tmp_path):
    # the path moves the camera every frame: frame 1 is reduced, Esc on frame 2 renders that
    # frame at full size for --screenshot, then quits
    shot = tmp_path / "esc.png"
    frames, summary, _ = run_window(SMALL + ["--technique", "clustered", "--path", "--move-scale", "0.5",
                                             "--json", "--keys", "f1,f1,escape", "--screenshot", str(shot)])
    assert [f["scale"] for f in frames] == [1.0, 0.5, 1.0] and summary["frames"] == 3
    assert summary["screenshots"] == [str(shot)] and load_rgb(shot).shape == (90, 160, 3)
