"""The capture CLI and dump contract, through the command line as users run it."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
from PIL import Image

from app.dump import FIELDS, read_dump

ROOT = Path(__file__).resolve().parents[2]


def capture(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "app.capture", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def test_list_names_scenes_and_techniques():
    out = capture("--list").stdout
    from app.techniques import REGISTRY
    from scenes import BUILTIN_SCENES
    assert all(n in out for n in BUILTIN_SCENES) and all(t in out for t in REGISTRY)


def test_dump_follows_the_contract(tmp_path):
    r = capture("--scene", "hangar", "--technique", "hybrid", "--lights", "300", "--seed", "7",
                "--size", "127x71", "--out", str(tmp_path / "f.png"), "--dump", str(tmp_path / "f.npz"),
                "--heatmap", str(tmp_path / "h.png"), "--classify", str(tmp_path / "c.png"))
    assert r.returncode == 0, r.stderr
    d = read_dump(tmp_path / "f.npz")
    with np.load(tmp_path / "f.npz") as raw:
        assert set(raw.files) == set(FIELDS) | {"meta"}
        assert raw["meta"].dtype.kind == "U"               # a JSON string
    assert d["image"].shape == (71, 127, 3) and d["image"].dtype == np.float32
    assert d["depth"].shape == (71, 127) and d["depth"].dtype == np.float32
    for k in ("evaluated", "contrib_count", "contrib_hash"):
        assert d[k].shape == (71, 127) and d[k].dtype == np.uint32
    assert (d["contrib_count"] <= d["evaluated"]).all() and d["contrib_count"].sum() > 0
    assert (d["evaluated"][d["depth"] == 0] == 0).all()     # sky: nothing shaded
    m = d["meta"]
    assert m["technique"] == "hybrid" and m["features"] == ["point"]
    assert {"cull", "sort", "bin", "build", "pack", "upload"} <= set(m["cpu_ms"])
    assert "shade" in m["gpu_ms"] and m["bytes"]["nodes"] > 0 and "options" in m
    assert Image.open(tmp_path / "f.png").size == (127, 71)
    assert Image.open(tmp_path / "h.png").size[0] > 127
    summary = json.loads(r.stdout)
    assert summary["technique"] == "hybrid" and summary["exact_per_pixel"] > 0
    assert summary["gpu_timing"].startswith("first frame") and "shade" in summary["gpu_ms"]


def test_capture_of_a_scene_file_matches_brute(tmp_path):
    scene = {"resolution": [64, 40],
             "camera": {"position": [0, 2, 10], "target": [0, 1, 0], "up": [0, 1, 0],
                        "fov_y_deg": 60, "near": 0.1, "far": 100},
             "geometry": [{"box": {"min": [-20, -0.1, -20], "max": [20, 0, 20]}, "albedo": [0.8, 0.8, 0.8]}],
             "lights": [{"type": "point", "position": [0, 1, 0], "radius": 3, "color": [1, 0.9, 0.8], "intensity": 5},
                        {"type": "spot", "position": [2, 4, 0], "direction": [0, -1, 0], "radius": 10,
                         "inner_angle_deg": 20, "outer_angle_deg": 30, "color": [1, 1, 1], "intensity": 20}]}
    path = tmp_path / "s.json"
    path.write_text(json.dumps(scene))
    dumps = {}
    for t in ("brute", "clustered"):
        r = capture("--scene", str(path), "--technique", t, "--dump", str(tmp_path / f"{t}.npz"))
        assert r.returncode == 0, r.stderr
        dumps[t] = read_dump(tmp_path / f"{t}.npz")
    assert dumps["brute"]["meta"]["features"] == ["point", "spot"]
    assert np.array_equal(dumps["brute"]["contrib_hash"], dumps["clustered"]["contrib_hash"])
    assert (dumps["brute"]["contrib_count"] == 2).any()


def test_bad_scene_file_is_one_line_exit_2(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text('{"resolution": [64, 40], "camera": {"position": [0,1,2], "target": [0,0,0]},'
                    ' "lights": [{"type": "point", "position": [0,0,0], "radius": -1}]}')
    r = capture("--scene", str(path), "--technique", "brute")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "radius" in r.stderr


def test_output_files_keep_their_names(tmp_path):
    """--dump x.png used to write x.png.npz silently: a file that is not what its flag
    writes is refused in one line, and nothing is written."""
    for flag, name in (("--dump", "x.png"), ("--out", "x.npz"), ("--heatmap", "h.jpg")):
        r = capture("--scene", "arena", "--lights", "10", "--size", "16x16", "--technique",
                    "brute", flag, str(tmp_path / name))
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert flag in r.stderr
    assert not list(tmp_path.iterdir())


def test_check_against_the_reference_and_warmup_apart(tmp_path):
    r = capture("--scene", "arena", "--lights", "300", "--size", "48x27", "--technique", "tree",
                "--check", str(tmp_path / "chk"), "--repeat", "3")
    assert r.returncode == 0, r.stderr
    assert "exact: tree equals brute" in r.stderr
    summary = json.loads(r.stdout)
    assert summary["cpu_warmup_ms"] >= 0 and "cull" in summary["cpu_ms"]
    # --repeat: the passes' median over the samples after the first frame (its compiles)
    assert summary["gpu_timing"] == "median of 3 samples after the first frame"
    lo, hi = summary["gpu_total_ms"]["min"], summary["gpu_total_ms"]["max"]
    assert 0 < lo <= hi and "shade" in summary["gpu_ms"]


def test_classify_needs_a_technique_with_the_classes_view(tmp_path):
    """A view the technique does not have is refused (the window offers the same views)."""
    r = capture("--scene", "arena", "--lights", "10", "--size", "16x16", "--technique", "tiled",
                "--classify", str(tmp_path / "c.png"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "tiled has no classes view" in r.stderr and "hybrid" in r.stderr
    assert not list(tmp_path.iterdir())


def test_pngs_are_what_the_window_shows(tmp_path):
    """--out is app.images.display of the dump's radiance (exposure, ambient: display only);
    --heatmap is the per-pixel heat map with a fixed top, then its colour bar."""
    from app import images
    r = capture("--scene", "hangar", "--technique", "clustered", "--lights", "200", "--size", "64x40",
                "--exposure", "2", "--ambient", "0", "--heat-max", "64", "--out", str(tmp_path / "f.png"),
                "--heatmap", str(tmp_path / "h.png"), "--dump", str(tmp_path / "f.npz"))
    assert r.returncode == 0, r.stderr
    d = read_dump(tmp_path / "f.npz")
    png = np.asarray(Image.open(tmp_path / "f.png").convert("RGB")).astype(int)
    assert np.abs(png - images.display(d["image"], None, 2.0, 0.0)).max() <= 1
    heat = np.asarray(Image.open(tmp_path / "h.png").convert("RGB")).astype(int)
    want = images.heat_rgb(d["evaluated"], d["depth"] > 0, 64.0)
    assert heat.shape[0] == 40 and np.array_equal(heat[:, :64], want)
    summary = json.loads(r.stdout)
    assert summary["display"] == {"exposure": 2.0, "ambient": 0.0, "heat_max": 64.0}
    # automatic exposure by default, and a faint ambient: the unlit geometry is not black
    r = capture("--scene", "hangar", "--technique", "clustered", "--lights", "1", "--size", "64x40",
                "--out", str(tmp_path / "dark.png"), "--dump", str(tmp_path / "dark.npz"))
    assert r.returncode == 0, r.stderr
    dark = np.asarray(Image.open(tmp_path / "dark.png").convert("RGB"))
    covered = read_dump(tmp_path / "dark.npz")["depth"] > 0
    assert (dark.max(2)[covered] >= 5).mean() > 0.95


def test_maps_of_a_techniques_own_structure(tmp_path):
    """fptl's coarse and pruned lists per tile (Mikkelsen's figures 2.4-2.6) as heat maps on
    one scale; a technique without maps says so."""
    r = capture("--scene", "gallery", "--technique", "fptl", "--size", "96x54", "--maps", str(tmp_path))
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fptl-coarse.png", "fptl-pruned.png"]
    assert Image.open(tmp_path / "fptl-coarse.png").size[0] > 96
    r = capture("--scene", "gallery", "--technique", "brute", "--size", "32x18", "--maps", str(tmp_path / "b"))
    assert r.returncode == 0 and "no maps of its own" in r.stderr
