"""The CPU stage's growth series: which techniques it runs, its rows'
counts and bytes, the cap, the thread count restored, the command without OpenGL, and the
report's reading of linear, fixed-cost and superlinear series."""
import json
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from app.bench import cpu as bench_cpu
from app.bench.presets import GPU_CHECK, GROWTH_LIGHTS, QUICK
from app.report.cpu import doubling_kinds, growth_report
from app.techniques import REGISTRY

ROOT = Path(__file__).resolve().parents[3]
COUNTS = (256, 512, 1024)


@pytest.fixture(scope="module")
def rows():
    return bench_cpu.growth_series("arena", COUNTS, (1, 2), (160, 90), 2)


def test_growth_runs_the_techniques_with_a_cpu_build(rows):
    import numba
    names = set(r["technique"] for r in rows)
    assert {"clustered", "tree", "hybrid", "zbin"} <= names
    assert "brute" not in names and "perfect" not in names      # cull, sort, pack only
    for t in names:
        got = sorted((int(r["lights"]), json.loads(r["stats"])["threads"])
                     for r in rows if r["technique"] == t)
        assert got == sorted((n, k) for n in COUNTS for k in (1, 2)), t
    assert numba.get_num_threads() == bench_cpu.set_cpu_threads(0)


def test_growth_rows_hold_every_buffer_and_stage(rows):
    from cpu_prep import layouts
    for r in rows:
        st = json.loads(r["stats"])
        b = st["buffer_bytes"]
        assert r["study"] == "growth" and r["samples"] == 2
        assert r["bytes_lights"] == b["lights"] == r["visible"] * layouts.GPU_LIGHT.itemsize
        assert r["bytes_culling"] == sum(b.values()) - b["lights"] > 0
        assert r["cpu_total_min_ms"] <= r["cpu_total_ms"] <= r["cpu_total_max_ms"]
        assert r["cpu_bin_ms"] + r["cpu_build_ms"] > 0
        assert 0 < r["visible"] <= r["lights"]
    # the list entries grow with the lights (arena: uniform lights, radii drawn alike)
    cl = {r["lights"]: json.loads(r["stats"])["list_entries"] for r in rows
          if r["technique"] == "clustered" and json.loads(r["stats"])["threads"] == 1}
    assert cl[256] < cl[512] < cl[1024]


def test_growth_cap_stops_a_technique():
    rows = bench_cpu.growth_series("arena", COUNTS, (1,), (96, 54), 1, techniques=["clustered"],
                                   cap_ms=1e-9)
    assert [r["lights"] for r in rows] == [COUNTS[0]]
    assert bench_cpu.growth_series("no-such.json", COUNTS, (1,), (96, 54), 1) == []


def test_presets():
    assert GROWTH_LIGHTS == tuple(8192 * 2 ** k for k in range(8)) and GROWTH_LIGHTS[-1] == 1 << 20
    growth = QUICK.config("growth")
    assert growth.lights == GROWTH_LIGHTS and growth.threads == (1, 2)
    assert growth.cap_ms > 0 and GPU_CHECK.config("growth").lights == ()


def _row(t, n, ms, threads=1, spread=0.02, bins=0.5, cells=0, nbytes=None):
    lo, hi = ms * (1 - spread), ms * (1 + spread)
    stages = {"cull": 0.1 * ms, "sort": 0.1 * ms, "pack": 0.2 * ms, "bin": bins * ms,
              "build": (0.6 - bins) * ms}
    nb = nbytes if nbytes is not None else 100 * n
    r = {"study": "growth", "scene": "arena", "lights": float(n), "visible": float(n),
         "width": 1920.0, "height": 1080.0, "technique": t, "cpu_total_ms": ms,
         "cpu_total_min_ms": lo, "cpu_total_max_ms": hi, "bytes_lights": 84.0 * n,
         "bytes_culling": float(nb),
         "stats": json.dumps({"threads": threads, "cells": cells, "caches": {"L2": 1 << 20},
                              "buffer_bytes": {"lights": 84 * n, "entries": nb}})}
    r.update({f"cpu_{k}_ms": v for k, v in stages.items()})
    r["cpu_upload_ms"] = 0.0
    return r


def test_report_reads_linear_fixed_and_superlinear(tmp_path):
    counts = [8192 << k for k in range(5)]
    rows = ([_row("lin", n, n / 8192) for n in counts]
            + [_row("lin", n, n / 16384, threads=2) for n in counts]
            + [_row("fixed", n, 5.0 + n / 8192, cells=14720, nbytes=4_000_000) for n in counts]
            + [_row("super", n, (n / 8192) ** (1.0 if n <= 32768 else 1.6), bins=0.1)
               for n in counts])
    kinds = {t: doubling_kinds(sorted((r for r in rows if r["technique"] == t and
                                       json.loads(r["stats"])["threads"] == 1),
                                      key=lambda r: r["lights"])) for t in ("lin", "fixed", "super")}
    assert kinds["lin"] == ["linear"] * 4
    assert kinds["fixed"][0] == "sub"
    assert kinds["super"] == ["linear", "linear", "super", "super"]
    png, text, tables = growth_report(rows, tmp_path)
    assert png == "cpu_growth.png" and (tmp_path / png).stat().st_size > 0
    line = {t: next(x for x in text if x.startswith(f"{t} (")) for t in ("lin", "fixed", "super")}
    assert "No doubling departs from linear" in line["lin"]
    assert "2 threads: 2.00x the speed" in line["lin"]
    assert "grows slower than the lights" in line["fixed"] and "14,720 cells" in line["fixed"]
    assert "From 32k to 64k it stops growing linearly" in line["super"]
    assert "build adds the most" in line["super"]
    assert "growing slower than the lights" in line["fixed"]      # 4 MB fixed, then lights
    assert "| lin | 2 |" in tables and "| 8k | 16k | 32k | 64k | 128k |" in tables
    assert growth_report([r for r in rows if r["technique"] == "x"], tmp_path) == (None, [], "")


def test_growth_command(tmp_path):
    """(test_bench_cpu.py holds the command to importing no OpenGL.)"""
    code = "import sys; from app import bench; bench.main(sys.argv[1:])"
    argv = ["cpu", "--growth", "--scene", "arena", "--technique", "clustered,tree",
            "--sweep", "256,512", "--threads", "1", "--repeat", "1", "--size", "96x54",
            "--out", str(tmp_path), "--json"]
    p = subprocess.run([sys.executable, "-c", code, *argv], cwd=ROOT, capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert sorted((r["technique"], r["lights"]) for r in d["rows"]) == \
        [("clustered", 256), ("clustered", 512), ("tree", 256), ("tree", 512)]
    for f in ("growth.csv", "cpu_growth.png", "growth.md"):
        assert (tmp_path / f).stat().st_size > 0, f
    assert "clustered (1 thread)" in (tmp_path / "growth.md").read_text()
