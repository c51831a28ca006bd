"""`python -m app.bench gpu-build` (app/bench/gpu_build.py) and its report section
(app/report/cpu.py gpu_build_report): a row per technique and count with both builds'
times and the GPU build's passes, gpu_build.csv that the report's CPU page reads, and a
one-line refusal of a technique that does not take --build."""
from __future__ import annotations

import json

import pytest

from app.bench import main as bench_main
from app.bench.gpu_build import CSV, gpu_techniques
from app.errors import UserError
from app.report.cpu import fig_cpu
from app.results import read_csv


def test_gpu_build_bench_writes_rows_the_report_reads(gl, tmp_path):
    bench_main(["gpu-build", "--sweep", "300,600", "--size", "32x18", "--repeat", "1",
                "--technique", "clustered,zbin", "--out", str(tmp_path)])
    rows = read_csv(tmp_path / CSV)
    assert [(r["technique"], int(r["lights"])) for r in rows] == [
        ("clustered", 300), ("zbin", 300), ("clustered", 600), ("zbin", 600)]
    for r in rows:
        s = json.loads(r["stats"])
        assert r["cpu_total_min_ms"] > 0 and s["gpu_build_min_ms"] > 0
        assert {"build_cull", "build_sort", "build_pack"} <= set(s["passes"])
        assert abs(s["gpu_over_cpu"] - s["gpu_build_min_ms"] / r["cpu_total_min_ms"]) < 0.01 * s["gpu_over_cpu"] + 0.01
    _, _, table = fig_cpu([], tmp_path)          # no results.csv rows: gpu_build.csv alone
    assert "### The build on the CPU and on the GPU" in table
    assert "zbin: the GPU build takes" in table and "| zbin | 600 |" in table
    assert (tmp_path / "gpu_build.md").read_text().count("| clustered |") == 2


def test_gpu_build_bench_refuses_a_technique_without_the_option(gl):
    assert set(gpu_techniques()) == {"clustered", "tree", "hybrid", "zbin"}
    with pytest.raises(UserError, match="--technique tiled: it does not take --build"):
        bench_main(["gpu-build", "--technique", "tiled", "--sweep", "300"])
