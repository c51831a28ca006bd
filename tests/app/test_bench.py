"""The benchmark: a tiny sweep through the --quick code path (every registered technique, every
plot, the report), the perfect culler's exactness, and `bench cpu --json` without GL."""
import json
import math
from pathlib import Path
import re
import subprocess
import sys

import numpy as np
import pytest

from app import bench
from app.techniques import REGISTRY, Options
from tests.helpers import make_scene, random_lights

ROOT = Path(__file__).resolve().parents[2]
TINY = ["--quick", "--size", "64x36", "--scenes", "arena", "--frames", "1", "--lights", "256",
        "--repeat", "1", "--cpu-lights", "256", "--cpu-size", "64x36"]
PLOTS = ("accuracy_cost.png", "gpu_path.png", "cpu_stages.png", "tile_size.png", "heatmaps.png",
         "cutoff.png", "options.png")


@pytest.fixture(scope="module")
def sweep(gl, tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    bench.main(TINY + ["--out", str(out)])
    return out, bench.read_csv(out / "results.csv")


def test_results_columns_and_rows(sweep):
    out, rows = sweep
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    assert header == bench.COLUMNS
    for study in ("path", "cutoff", "cpu"):
        got = {r["technique"] for r in rows if r["study"] == study}
        want = set(REGISTRY) | ({bench.PERFECT} if study != "cpu" else set())
        assert got == want, f"{study}: {sorted(got)} != {sorted(want)}"
    assert {r["study"] for r in rows} == {"path", "tile", "radius", "layout", "cutoff", "cpu",
                                          "cpu_tile"}
    for study in ("tile", "cpu_tile"):
        assert {r["tile"] for r in rows if r["study"] == study} == {16.0, 32.0, 48.0, 64.0}


def test_exactness_and_waste(sweep):
    _, rows = sweep
    rendered = [r for r in rows if not r["study"].startswith("cpu")]
    assert rendered
    for r in rendered:
        where = f"{r['study']} {r['technique']} cutoff {r['cutoff']}"
        assert r["mismatch_count"] == 0 and r["mismatch_hash"] == 0, where
        if r["exact_pp"] > 0:
            assert r["waste"] >= 1.0, where
        if r["technique"] == bench.PERFECT:
            assert r["evaluated_pp"] == r["exact_pp"], where
            assert r["waste"] == 1.0 or r["exact_pp"] == 0, where
        if r["error_ref"] == bench.REFERENCE:
            assert r["image_error"] < 1e-5, where
        assert r["gpu_shade_ms"] > 0 and r["samples"] >= 1, where
    # the unbounded reference lies above every cutoff's error, and error falls as t falls
    cut = [r for r in rendered if r["study"] == "cutoff" and r["technique"] == bench.REFERENCE
           and r["cutoff"] > 0]
    errs = [r["image_error"] for r in sorted(cut, key=lambda r: r["cutoff"])]
    assert all(a >= b for a, b in zip(errs, errs[1:])), errs


def test_plots_and_report(sweep):
    out, _ = sweep
    report = (out / "report.md").read_text()
    for name in PLOTS:
        assert (out / name).stat().st_size > 1000, name
    for png in out.glob("*.png"):
        assert f"]({png.name})" in report, f"report.md does not show {png.name}"
    for t in REGISTRY:
        assert t in report
    assert "llvmpipe" not in report.lower() or "only comparable as ratios" in report
    assert re.search(r"^- command: `python -m app.bench ", report, re.M)


def test_perfect_culler_exact_lists(gl, rng):
    from app.perfect import PerfectCuller
    from app.renderer import Renderer
    scene = make_scene(random_lights(rng, 300, (-12, 0, -40), (12, 8, 5)), size=(61, 37))
    r = Renderer(scene)
    try:
        ref = r.render(REGISTRY[bench.REFERENCE], 0, Options())
        p = PerfectCuller(r)
        one = p.render(0, Options())
        again = p.render(0, Options())          # same frame: the lists are reused
        assert again.meta["stats"]["lists_reused"] and not one.meta["stats"]["lists_reused"]
        assert np.array_equal(again.contrib_hash, one.contrib_hash)
        gl_rows = one.contrib_count[::-1].astype(np.int64)      # GL row order, bottom first
        per_group = [int(gl_rows[y:y + 8].sum()) for y in range(0, gl_rows.shape[0], 8)]
        p.max_band_bytes = 4 * max(per_group)   # force several bands of whole 8-row groups
        assert sum(per_group) > max(per_group)
        banded = p.render(0, Options())
        assert banded.meta["stats"]["bands"] > 1
        for res in (one, banded):
            assert (res.evaluated == res.contrib_count).all()
            assert (res.contrib_count == ref.contrib_count).all()
            assert (res.contrib_hash == ref.contrib_hash).all()
            assert np.array_equal(res.image, ref.image)
            assert set(res.meta["gpu_ms"]) == {"gbuffer", "shade"}
        assert ref.contrib_count.sum() > 0
        p.release()
    finally:
        r.release()


def test_cutoff_rule():
    lights = random_lights(np.random.default_rng(1), 200, (0, 0, 0), (1, 1, 1))
    lights["intensity"] = np.linspace(0.1, 10.0, 200)
    lights["color"] = 1.0
    a = bench.cutoff_lights(lights, 1 / 256)
    b = bench.cutoff_lights(lights, 1 / 1024)
    assert 0 < len(a) <= len(b) <= len(lights)
    i = bench.light_intensity(a)
    assert np.allclose(a["radius"], np.sqrt(i / (10.0 / 256) - 1), rtol=1e-5)
    assert np.all(np.diff(a["radius"]) > 0)        # brighter -> larger: the law is kept
    assert a["radius"].max() == pytest.approx(math.sqrt(255), rel=1e-5)


def test_bench_cpu_json_without_gl():
    code = ("import sys; from app import bench; bench.main(sys.argv[1:]); "
            "assert 'moderngl' not in sys.modules, 'bench cpu imported moderngl'")
    argv = ["cpu", "--scene", "arena", "--technique", next(iter(REGISTRY)), "--lights", "512",
            "--size", "320x180", "--tile", "48", "--slices", "16", "--repeat", "2", "--json"]
    p = subprocess.run([sys.executable, "-c", code, *argv], cwd=ROOT, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    lines = [l for l in p.stdout.splitlines() if l.strip()]
    assert len(lines) == 1
    d = json.loads(lines[0])
    for k in ("median_ms", "min_ms", "max_ms"):
        assert set(d[k]) == set(bench.CPU_STAGES) | {"total"}
    assert d["lights"] == 512 and 0 < d["visible"] <= 512
    assert d["median_ms"]["total"] > 0


def test_bench_errors_are_one_line(capsys):
    from app.cli import run_main
    with pytest.raises(SystemExit) as e:
        run_main(lambda: bench.main(["cpu", "--technique", "no-such-technique"]))
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no-such-technique" in err[0]
