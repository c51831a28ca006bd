"""`python -m app.bench --path PATH.json`: every technique along a camera path file (the
window's --record format), a per-frame CSV; and `bench --help` naming its subcommands."""
import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from app import bench
from app.techniques import REGISTRY, with_role
from tests.helpers import path_file

ROOT = Path(__file__).resolve().parents[3]


def test_every_technique_along_the_path(gl, tmp_path):
    out = tmp_path / "out"
    bench.main(["--path", str(path_file(tmp_path)), "--out", str(out), "--size", "64x36",
                "--lights", "256", "--tile", "16"])
    with open(out / "path.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 3 * len(REGISTRY)
    assert [r["technique"] for r in rows[:len(REGISTRY)]][0] == with_role("reference").name
    assert {r["technique"] for r in rows} == set(REGISTRY)
    assert sorted({int(r["frame"]) for r in rows}) == [0, 1, 2]
    for r in rows:
        t = REGISTRY[r["technique"]]
        assert r["scene"] == "arena" and (r["width"], r["height"]) == ("64", "36")
        assert int(r["mismatch_pixels"]) == 0, r["technique"]
        assert float(r["gpu_shade_ms"]) > 0 and float(r["gpu_gbuffer_ms"]) > 0
        assert float(r["cpu_cull_ms"]) >= 0 and float(r["cpu_total_ms"]) > 0
        assert float(r["evaluated_pp"]) >= float(r["exact_pp"]) >= 0
        assert float(r["frame_cost_ms"]) >= float(r["gpu_lighting_ms"])
        # each technique takes the option flags it declares
        assert (r["tile"] == "16") == ("tile" in t.Options.names())
    tiled = [r for r in rows if r["technique"] == "tiled"]
    assert tiled and all(float(r["gpu_tile_cull_ms"]) > 0 for r in tiled)
    assert all(r["gpu_tile_cull_ms"] == "" for r in rows if r["technique"] == "clustered")
    info = json.loads((out / "path.json").read_text())
    assert info["keys"] == 3 and set(info["medians"]) == set(REGISTRY)
    assert (out / "path.png").stat().st_size > 1000


def test_subset_and_bad_files(gl, tmp_path):
    out = tmp_path / "sub"
    bench.main(["--path", str(path_file(tmp_path, 2)), "--out", str(out), "--size", "32x18",
                "--lights", "64", "--techniques", "clustered,tree"])
    with open(out / "path.csv") as f:
        assert {r["technique"] for r in csv.DictReader(f)} == {"clustered", "tree"}
    bad = tmp_path / "bad.json"
    bad.write_text('{"keys": [{"position": [0, 1, 2]}]}')
    for args in (["--path", str(bad)], ["--path", str(tmp_path / "none.json")],
                 ["--path", str(path_file(tmp_path)), "--techniques", "nope"]):
        r = subprocess.run([sys.executable, "-m", "app.bench", *args, "--out", str(tmp_path / "x")],
                           cwd=ROOT, capture_output=True, text=True, timeout=120)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert "Traceback" not in r.stderr


def test_help_lists_the_subcommands():
    r = subprocess.run([sys.executable, "-m", "app.bench", "--help"], cwd=ROOT,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0
    assert "python -m app.bench cpu" in r.stdout and "--path PATH.json" in r.stdout
    assert "--quick" in r.stdout                         # the sweep's own flags follow


def test_the_lights_move_along_the_path_with_motion(gl, tmp_path):
    """--motion bounce: frame k of the path renders the lights at k of len(path) frames
    (scenes.motion); with the camera held still the light sets change, exactly."""
    p = path_file(tmp_path)
    d = json.loads(p.read_text())
    d["keys"] = [dict(d["keys"][0], t=k) for k in range(3)]            # a camera that stands still
    p.write_text(json.dumps(d))
    out = tmp_path / "moving"
    bench.main(["--path", str(p), "--out", str(out), "--size", "48x27", "--lights", "256",
                "--techniques", "clustered", "--motion", "bounce"])
    with open(out / "path.csv") as f:
        rows = list(csv.DictReader(f))
    assert all(int(r["mismatch_pixels"]) == 0 for r in rows)
    # a still camera over still lights gives one structure; here it changes frame to frame
    assert len({(r["exact_pp"], r["evaluated_pp"]) for r in rows if r["technique"] == "clustered"}) > 1
    assert json.loads((out / "path.json").read_text())["motion"]["kind"] == "bounce"
