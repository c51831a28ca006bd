"""capture --views stereo (app.stereo_capture), through the command line as users run it."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from app.dump import read_dump

ROOT = Path(__file__).resolve().parents[2]
SMALL = ("--scene", "arena", "--lights", "512", "--size", "64x36")


def capture(*args):
    return subprocess.run([sys.executable, "-m", "app.capture", *SMALL, *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def test_stereo_writes_each_eye_and_checks_each(tmp_path):
    r = capture("--technique", "clustered", "--views", "stereo", "--stereo-way", "union",
                "--eye-separation", "0.5", "--out", str(tmp_path / "f.png"),
                "--dump", str(tmp_path / "d.npz"), "--check", str(tmp_path / "chk"))
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == \
        ["d-left.npz", "d-right.npz", "f-left.png", "f-right.png"]
    dumps = {e: read_dump(tmp_path / f"d-{e}.npz") for e in ("left", "right")}
    for eye, d in dumps.items():
        m = d["meta"]
        assert (m["eye"], m["way"], m["separation"], m["share"]) == (eye, "union", 0.5, "structure")
        assert d["contrib_count"].shape == (36, 64)
    # two views: the eyes see the scene from 0.5 m apart
    assert not np.array_equal(dumps["left"]["depth"], dumps["right"]["depth"])
    assert [ln for ln in r.stderr.splitlines() if ln.startswith("exact: ")] == \
        ["exact: left eye (union): clustered's equals brute at every pixel",
         "exact: right eye (union): clustered's equals brute at every pixel"]
    line = json.loads(r.stdout)
    assert line["views"] == "stereo" and set(line["eyes"]) == {"left", "right"}


def test_a_samplers_eyes_are_checked_for_support_and_bias(tmp_path):
    r = capture("--technique", "sample-list", "--views", "stereo", "--stereo-way", "union",
                "--check", str(tmp_path / "chk"))
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("exact support: ")]
    assert len(lines) == 2 and all("unbiased within its noise" in ln for ln in lines), r.stderr


def test_mono_is_unchanged(tmp_path):
    r = capture("--technique", "tree", "--dump", str(tmp_path / "d.npz"))
    assert r.returncode == 0, r.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["d.npz"]
    assert not {"eye", "way", "separation"} & set(read_dump(tmp_path / "d.npz")["meta"])


def test_bad_stereo_input_is_one_line_exit_2(tmp_path):
    cases = [(("--views", "both"), "--views"),
             (("--stereo-way", "union"), "--stereo-way needs --views stereo"),
             (("--eye-separation", "0.1"), "--eye-separation needs --views stereo"),
             (("--views", "stereo", "--eye-separation", "-1"), "--eye-separation -1"),
             (("--views", "stereo", "--stereo-way", "all"), "--stereo-way"),
             (("--views", "stereo", "--stereo-way", "union", "--technique", "clustered",
               "--build", "gpu"), "cannot share --build gpu"),
             (("--views", "stereo", "--technique", "tree", "--classify", str(tmp_path / "c.png")),
              "--classify is a mono figure")]
    for args, needle in cases:
        r = capture(*args)
        assert r.returncode == 2, (args, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and needle in lines[0], (args, r.stderr)


def test_a_fog_scenes_eyes_are_checked_on_their_froxels_and_union_refuses_it(tmp_path):
    fog = ("--scene", "hangar-fog", "--lights", "256", "--froxels", "16x9x8")
    r = capture(*fog, "--technique", "clustered", "--views", "stereo",
                "--dump", str(tmp_path / "d.npz"), "--check", str(tmp_path / "chk"))
    assert r.returncode == 0, r.stderr
    assert [ln for ln in r.stderr.splitlines() if ln.startswith("exact: ")] == \
        [f"exact: {e} eye (per-view): clustered's equals brute at every pixel and every froxel"
         for e in ("left", "right")]
    d = read_dump(tmp_path / "d-left.npz")
    assert d["froxel_count"].shape == (8, 9, 16) and d["froxel_count"].any()
    r = capture(*fog, "--technique", "clustered", "--views", "stereo", "--stereo-way", "union")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "per-view" in r.stderr
