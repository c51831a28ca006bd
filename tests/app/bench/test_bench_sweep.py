"""The benchmark sweep end to end: a tiny run through the --quick code path (every registered
technique, every study, every plot, the report), read back through the results schema."""
import math
import re

import numba
import pytest

from app import bench, report
from app.bench.caps import CAPS
from app.bench.cpu import GROWTH
from app.bench.c_reference.compare import STUDY as C_REFERENCE, TECHNIQUES as C_TECHNIQUES
from app.bench.gpu_build import STUDY as GPU_BUILD, gpu_techniques
from app.results import CPU_PREFIX, columns, option_studies, read_csv
from app.techniques import REGISTRY, parts, with_role
from tests.app.techniques.throwaway import Throwaway
from tests.helpers import registered

TINY = ["--quick", "--size", "64x36", "--scenes", "arena", "--frames", "1", "--lights", "256",
        "--repeat", "1", "--cpu-lights", "256", "--cpu-size", "96x54", "--growth-lights", "256,512",
        "--gpu-build-lights", "256", "--c-reference-lights", "256", "--temporal-frames", "0"]
# (the temporal series has its own tests: tests/app/bench/test_temporal.py)
# the CPU series at another resolution than the rendered one: the cpu_<option> rows run too
FIXED_PLOTS = ("accuracy_cost.png", "gpu_path.png", "cpu_stages.png", "heatmaps.png", "cutoff.png",
               "tradeoff.png")


@pytest.fixture(scope="module")
def sweep(gl, tmp_path_factory):
    """The tiny sweep, with test_frame_graph's throw-away technique registered: a technique
    module takes part in every study with no other file changed (the registry is its
    only link), checked by every test here against REGISTRY."""
    out = tmp_path_factory.mktemp("bench")
    with registered(Throwaway()):
        bench.main(TINY + ["--out", str(out)])
        yield out, read_csv(out / "results.csv")


def test_a_new_technique_module_takes_part(sweep):
    out, rows = sweep
    mine = [r for r in rows if r["technique"] == "throwaway"]
    assert {r["study"] for r in mine} >= {"path", "cutoff", "cpu"}
    assert all(r["mismatch_count"] == 0 and r["mismatch_hash"] == 0 for r in mine if r["study"] == "path")
    assert "throwaway" in (out / "report.md").read_text()


def test_the_run_says_where_its_time_went(sweep):
    """run.json's study_s: each study of the preset's, in order, its wall seconds; and the
    sweep wrote no other command's file (temporal.csv: --temporal-frames 0, none)."""
    import json
    from app.bench.presets import STUDY_ORDER
    out, _ = sweep
    info = json.loads((out / "run.json").read_text())
    spent = info["study_s"]
    assert list(spent) == list(STUDY_ORDER) and all(v >= 0 for v in spent.values())
    assert info["report_s"] > 0
    # and by phase within each study (app.pipeline.phases), adding up to its wall time
    by_phase = info["phase_s"]
    assert list(by_phase) == list(STUDY_ORDER)
    assert {"render", "compile", "check"} <= set(by_phase["rendered"])
    for name, s in spent.items():
        assert sum(by_phase[name].values()) == pytest.approx(s, rel=0.01, abs=0.01), name
    assert "where the time went" in (out / "report.md").read_text()
    names = {p.name for p in out.iterdir()}
    assert not names & {"temporal.csv", "gpu_build.csv", "growth.csv", "path.csv"}


def test_results_columns_and_rows(sweep):
    out, rows = sweep
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    assert header == columns()
    for study in ("path", "cutoff", "cpu"):
        got = {r["technique"] for r in rows if r["study"] == study}
        assert got == set(REGISTRY), f"{study}: {sorted(got)} != {sorted(REGISTRY)}"
    studies = option_studies()
    assert studies, "no option declares study values"
    assert {r["study"] for r in rows} == {"path", "cutoff", "cpu", CAPS, GROWTH, GPU_BUILD, C_REFERENCE} | set(studies) | \
        {CPU_PREFIX + s for s in studies}
    for name, (spec, techs) in studies.items():
        for study in (name, CPU_PREFIX + name):
            sub = [r for r in rows if r["study"] == study]
            assert {r["technique"] for r in sub} == set(techs), study
            assert {r[name] for r in sub} == {float(v) for v in spec.study}, study
    for r in rows:      # option columns: blank exactly where the technique lacks the option
        names = REGISTRY[r["technique"]].Options.names()
        for name in studies:
            assert math.isnan(r[name]) == (name not in names), (r["technique"], name)
        assert r["role"] == REGISTRY[r["technique"]].role


def test_exactness_waste_and_cost(sweep):
    _, rows = sweep
    ref, floor = with_role("reference").name, with_role("floor").name
    rendered = [r for r in rows if not r["study"].startswith(CPU_PREFIX)
                and r["study"] not in ("cpu", GROWTH, GPU_BUILD, C_REFERENCE)]
    assert rendered
    for r in rendered:
        where = f"{r['study']} {r['technique']} cutoff {r['cutoff']}"
        assert r["mismatch_count"] == 0 and r["mismatch_hash"] == 0, where
        sampler = REGISTRY[r["technique"]].role == "sampler"
        if r["exact_pp"] > 0 and not sampler:      # a sampler may evaluate fewer than it can reach
            assert r["waste"] >= 1.0, where
        if r["technique"] == floor:
            assert r["evaluated_pp"] == r["exact_pp"], where
            assert r["waste"] == 1.0 or r["exact_pp"] == 0, where
            assert r["setup_ms"] > 0, where          # its lists: untimed set-up ...
            assert set(p.split("=")[0] for p in r["gpu_passes"].split(";")) == {"gbuffer", "shade"}
        if r["error_ref"] == ref:      # exact: brute's image; a sampler: its noise
            assert (r["image_error"] > 1e-3) if sampler else (r["image_error"] < 1e-5), where
        assert r["gpu_shade_ms"] > 0 and r["samples"] >= 1, where
        # ... never part of the cost: CPU stage + every timed pass but the G-buffer (1 sample)
        assert r["frame_cost_ms"] == pytest.approx(
            r["cpu_total_ms"] + r["gpu_cull_ms"] + r["gpu_shade_ms"], abs=2e-4), where
        assert r["gpu_lighting_min_ms"] <= r["gpu_lighting_ms"] <= r["gpu_lighting_max_ms"], where
    # the unbounded reference lies above every cutoff's error, and error falls as t falls
    cut = [r for r in rendered if r["study"] == "cutoff" and r["technique"] == ref and r["cutoff"] > 0]
    errs = [r["image_error"] for r in sorted(cut, key=lambda r: r["cutoff"])]
    assert all(a >= b for a, b in zip(errs, errs[1:])), errs


def test_plots_and_report(sweep):
    out, _ = sweep
    text = (out / "report.md").read_text()
    plots = FIXED_PLOTS + tuple(f"option_{s}.png" for s in option_studies())
    for name in plots:
        assert (out / name).stat().st_size > 1000, name
    for png in out.glob("*.png"):
        assert f"]({png.name})" in text, f"report.md does not show {png.name}"
    for t in REGISTRY:
        assert t in text
    assert "llvmpipe" not in text.lower() or "only comparable as ratios" in text
    assert re.search(r"^- command: `python -m app.bench ", text, re.M)
    # one sample a rendered configuration: no difference of its timings may be called a
    # finding (the CPU-only series has cpu_repeat samples: it may)
    assert "one sample" in text
    assert not re.search(r"fastest over the path|is lowest at|(GPU lighting|frame cost) "
                         r"[0-9.]+x \((higher|lower) beyond spread", text)


def test_gpu_build_comparison(sweep):
    """The sweep builds every --build technique on the CPU and on the GPU at
    each gpu_build count (study "gpu_build" of results.csv), and the CPU page compares them."""
    import json
    out, rows = sweep
    got = [r for r in rows if r["study"] == GPU_BUILD]
    assert {(r["technique"], int(r["lights"])) for r in got} == {(t, 256) for t in gpu_techniques()}
    for r in got:
        s = json.loads(r["stats"])
        assert s["gpu_build_min_ms"] > 0 and r["cpu_total_min_ms"] > 0, r["technique"]
        # the ratio is of the unrounded times, the columns are rounded: 1% (a 0.01 ms column
        # of a ~0.1 ms CPU stage moves a ~50x ratio by more than its own rounding)
        assert s["gpu_over_cpu"] == pytest.approx(s["gpu_build_min_ms"] / r["cpu_total_min_ms"], rel=0.01)
    text = (out / "report.md").read_text()
    assert "### The build on the CPU and on the GPU" in text
    assert "| technique | lights | visible | CPU stage ms | GPU build ms | GPU / CPU |" in text
    for t in gpu_techniques():
        assert re.search(rf"^\| {t} \| 256 \| ", text, re.M), t
        assert f"{t}: the GPU build takes " in text
    assert not (out / "gpu_build.csv").exists()       # results.csv holds them


def test_c_reference_comparison(sweep):
    """The sweep runs hybrid's and clustered's CPU stage against the plain C
    reference on one and two numba threads (study "c_reference"), the outputs identical, and
    the CPU page sets them side by side."""
    import json
    out, rows = sweep
    got = [r for r in rows if r["study"] == C_REFERENCE]
    assert sorted((r["technique"], int(r["lights"]), json.loads(r["stats"])["threads"]) for r in got) == \
        sorted((t, 256, min(k, numba.config.NUMBA_NUM_THREADS)) for t in C_TECHNIQUES for k in (1, 2))
    for r in got:
        s = json.loads(r["stats"])
        assert s["identical"] and s["c_min_ms"] > 0 and r["cpu_total_min_ms"] > 0, r["technique"]
        assert s["ratio_min"] == pytest.approx(r["cpu_total_min_ms"] / s["c_min_ms"], rel=0.02)
    text = (out / "report.md").read_text()
    assert "### Against plain single-threaded C" in text
    for t in C_TECHNIQUES:
        assert re.search(rf"^\| {t} \| 256 \| \d+ \| 1 \| .* \| identical \|$", text, re.M), t
        assert f"{t} at 256 lights: ours takes " in text


def test_report_rebuilds_from_the_folder(sweep, monkeypatch):
    """`python -m app.report DIR` gives the same report.md from the folder's files.  What is
    checked is the text: the plots (every one drawn and shown by the sweep's own report,
    test_plots_and_report) are built again but neither laid out nor drawn here (half the
    rebuild's time)."""
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import TightLayoutEngine
    out, _ = sweep
    before = (out / "report.md").read_text()
    (out / "report.md").unlink()
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: None)
    monkeypatch.setattr(TightLayoutEngine, "execute", lambda self, fig: None)
    report.main([str(out)])
    after = (out / "report.md").read_text()
    strip = lambda s: re.sub(r"run time: .*", "", s)
    assert strip(after) == strip(before)


def test_technique_notes_and_stats_column(sweep):
    """Techniques set their paper's figures beside the run's (report_notes, e.g. zbin's
    memory table from its own build); every rendered row carries its meta stats as JSON."""
    import json
    out, rows = sweep
    rendered = [r for r in rows if r["study"] == "path"]
    assert all("visible_lights" in json.loads(r["stats"]) for r in rendered)
    text = (out / "report.md").read_text()
    for name, t in REGISTRY.items():
        if parts.part(t, "paper") is not None:     # a technique without a paper gives none
            assert f"## {name}: " in text
    if "zbin" in REGISTRY:
        assert "| 1,036,800 B (its buffer's bytes) |" in text and "+ 32,384 B (its buffer's bytes)" in text
    # each technique's maps of its own structure, when any technique has them
    if any(type(t).maps is not type(REGISTRY[with_role("reference").name]).maps
           for t in REGISTRY.values()):
        assert "](technique_maps.png)" in text


def test_presets_wire_the_gpu_build_comparison():
    """--quick and --full compare the builds (full at more counts), gpu-check not;
    --gpu-build-lights overrides the counts (0: none), --scenes the scene, --repeat the samples."""
    from argparse import Namespace
    from app.bench.presets import FULL, GPU_CHECK, QUICK, preset_from_args
    def counts(p):
        return p.config("gpu_build").lights
    assert len(counts(QUICK)) >= 2 and len(counts(FULL)) > len(counts(QUICK))
    assert counts(GPU_CHECK) == ()
    blank = dict(full=False, gpu_check=False, size=None, scenes=None, lights=None, frames=None,
                 repeat=None, cpu_lights=None, cpu_size=None, threads=None)
    p = preset_from_args(Namespace(**dict(blank, scenes="hangar,arena", repeat=2,
                                          gpu_build_lights="512,1024")))
    c = p.config("gpu_build")
    assert (c.scene, c.lights, c.repeat) == ("hangar", (512, 1024), 2)
    assert counts(preset_from_args(Namespace(**dict(blank, gpu_build_lights="0")))) == ()
    assert counts(preset_from_args(Namespace(**blank))) == counts(QUICK)


def test_image_flip_computes_a_pair_once(monkeypatch):
    """measure.image_flip: FLIP of one (reference, frame) image pair is computed once (the
    cutoff and caps studies compare one exact image with the unbounded reference again and
    again); another pair is computed anew, and an identical pair is 0 with no FLIP at all."""
    from types import SimpleNamespace
    import flip_evaluator
    import numpy as np
    from app.bench import measure
    calls = []
    real = flip_evaluator.evaluate
    monkeypatch.setattr(flip_evaluator, "evaluate", lambda *a, **k: calls.append(1) or real(*a, **k))
    rng = np.random.default_rng(5)
    ref, a, b = (SimpleNamespace(image=rng.random((9, 11, 3), dtype=np.float32)) for _ in range(3))
    first = measure.image_flip(a, ref)
    assert first > 0 and measure.image_flip(SimpleNamespace(image=a.image.copy()), ref) == first
    assert len(calls) == 1
    assert measure.image_flip(b, ref) != first and len(calls) == 2
    assert measure.image_flip(ref, ref) == 0.0 and len(calls) == 2
