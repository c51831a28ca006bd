"""The first look's one page (app.summary, scripts/main.sh): every technique's heat map on one
scale, and the exactness line that counts the pixels differing from brute."""
from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from app import summary
from app.dump import write_dump
from app.errors import UserError
from app.techniques import REGISTRY

ROOT = Path(__file__).resolve().parents[2]


class Frame:
    """The fields write_dump takes from a FrameResult."""

    def __init__(self, name, evaluated, count, hash_, meta=None):
        h, w = count.shape
        self.image = np.full((h, w, 3), 0.5, np.float32)
        self.depth = np.ones((h, w), np.float32)
        self.depth[0, :] = 0.0                                   # a row of sky
        self.evaluated, self.contrib_count, self.contrib_hash = evaluated, count, hash_
        self.meta = dict(technique=name, scene="city", lights=64, seed=0, frame=0,
                         resolution=[w, h], cpu_ms={"cull": 1.0}, gpu_ms={"shade": 2.0},
                         bytes={"lights": 4096}, **(meta or {}))


def synthetic(folder: Path, differ: dict | None = None, names=("brute", "clustered", "fptl")):
    """Dumps of one 12x8 frame: brute evaluates 40 a pixel, the others fewer; `differ`
    {technique: pixels} changes that many pixels' hash."""
    rng = np.random.default_rng(3)
    count = rng.integers(0, 4, (8, 12)).astype(np.uint32)
    hash_ = rng.integers(0, 2**32, (8, 12), dtype=np.uint64).astype(np.uint32)
    folder.mkdir(parents=True, exist_ok=True)
    for k, name in enumerate(names):
        h = hash_.copy()
        n = (differ or {}).get(name, 0)
        h.ravel()[:n] ^= np.uint32(1)
        ev = count + (40 if name == "brute" else 2 * k)
        write_dump(folder / f"city-{name}.npz", Frame(name, ev.astype(np.uint32), count, h))


def test_the_page_of_an_exact_folder(tmp_path, capsys):
    synthetic(tmp_path / "capture")
    summary.main([str(tmp_path / "capture")])
    out = capsys.readouterr().out.splitlines()
    assert out[0] == ("Exact: all 2 techniques give brute's lights (contrib_count and contrib_hash) "
                      "at every one of 96 pixels: 0 pixels differ.")
    assert out[1] == f"summary: {tmp_path / 'summary.md'} ({tmp_path / 'summary.png'})"
    md = (tmp_path / "summary.md").read_text()
    assert out[0] in md and "![" in md and "(summary.png)" in md
    rows = [l for l in md.splitlines() if l.startswith("| ") and not l.startswith("| technique")]
    assert [r.split("|")[1].strip() for r in rows] == ["brute", "clustered", "fptl"]   # registry order
    brute = rows[0].split("|")
    assert brute[2].strip() == summary.num(float(np.mean(
        np.load(tmp_path / "capture" / "city-brute.npz")["evaluated"][1:])))
    png = Image.open(tmp_path / "summary.png")
    assert png.size[0] > 800 and png.size[1] > 400


def test_differing_pixels_are_counted_and_fail(tmp_path, capsys):
    synthetic(tmp_path / "capture", differ={"fptl": 5})
    with pytest.raises(SystemExit) as e:
        summary.main([str(tmp_path / "capture"), "--out", str(tmp_path / "page" / "first")])
    assert e.value.code == 1
    line = capsys.readouterr().out.splitlines()[0]
    assert line.startswith("NOT exact: 1 of 2 techniques differ from brute") and "fptl 5 px" in line
    assert "clustered" not in line
    assert (tmp_path / "page" / "first.png").is_file()
    assert "| fptl |" in (tmp_path / "page" / "first.md").read_text()


def test_figures_per_technique(tmp_path):
    synthetic(tmp_path, differ={"clustered": 3})
    figs = summary.figures(summary.load(tmp_path))
    assert figs["clustered"]["differ"] == 3 and figs["fptl"]["differ"] == 0
    assert figs["brute"]["pixels"] == 96
    d = np.load(tmp_path / "city-fptl.npz")
    covered = d["depth"] > 0
    assert figs["fptl"]["evaluated"] == pytest.approx(d["evaluated"][covered].mean())
    assert figs["fptl"]["waste"] == pytest.approx(d["evaluated"][covered].mean() / d["contrib_count"][covered].mean())
    assert figs["fptl"]["cpu_ms"] == 1.0 and figs["fptl"]["gpu_ms"] == 2.0 and figs["fptl"]["bytes"] == 4096


def test_bad_folders_are_one_line(tmp_path):
    with pytest.raises(UserError, match="no capture dumps"):
        summary.load(tmp_path)
    synthetic(tmp_path / "a", names=("clustered", "fptl"))
    with pytest.raises(UserError, match="no dump of the reference technique brute"):
        summary.load(tmp_path / "a")
    synthetic(tmp_path / "b")
    other = np.load(tmp_path / "b" / "city-fptl.npz")
    meta = json.loads(str(other["meta"]))
    meta["frame"] = 3
    np.savez(tmp_path / "b" / "city-fptl.npz", **{k: other[k] for k in other.files if k != "meta"},
             meta=np.array(json.dumps(meta)))
    with pytest.raises(UserError, match="another frame"):
        summary.load(tmp_path / "b")
    p = subprocess.run([sys.executable, "-m", "app.summary", str(tmp_path / "nope")], cwd=ROOT,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and p.stderr.strip().splitlines() == [f"error: {tmp_path / 'nope'}: no such folder"]


def test_real_captures_of_every_technique(gl, tmp_path, capsys):
    """Dumps as capture writes them (the renderer's own frames, every registered technique):
    the page shows them all and finds them exact."""
    from app.pipeline.renderer import Renderer
    from scenes import load_scene
    scene = load_scene("city", lights=256, seed=1)
    folder = tmp_path / "capture"
    folder.mkdir()
    with Renderer(scene, (64, 36)) as r:
        for name, t in REGISTRY.items():
            res = r.render(t, 0, t.Options.make({}))
            res.meta.update(scene="city", lights=256, seed=1)
            write_dump(folder / f"city-{name}.npz", res)
    summary.main([str(folder)])
    line = capsys.readouterr().out.splitlines()[0]
    assert line.startswith(f"Exact: all {len(REGISTRY) - 1} techniques") and "2,304 pixels" in line
    md = (tmp_path / "summary.md").read_text()
    assert all(f"| {n} |" in md for n in REGISTRY)
    assert md.splitlines()[0] == "# First look: city, 256 lights, 64x36, frame 0"
