"""The benchmark's report: PNG plots (matplotlib Agg) and report.md, from results.csv.

    python -m app.report DIR       rebuild DIR/report.md and its plots from DIR/results.csv,
                                   DIR/maps.npz and DIR/run.json (no rendering)

Every sentence that reads a plot is generated from the numbers of this run, and a timing
difference is called a finding only when it exceeds the measured spread (app.report.spread).
Techniques are iterated in the order they appear in the table (the registry's order), never
named here: the reference and the floor are found by role, and the option figures are made
for whatever options were studied.  This package reads the results schema (app.results)
and never imports the benchmark.

Modules: common (plotting and row helpers, roles, colours), spread (what counts as a
finding), aggregate (path means, Pareto front), accuracy, path, cpu, options, maps, cutoff,
temporal (one figure each; temporal reads DIR/temporal.csv, app.bench.temporal), tables, gpu (the modelled GPU cost, its Pareto fronts, which figure to
believe), validation (the model beside the papers' measurements), tradeoff (the lead
figure: image and temporal error against frame cost over cutoffs, cap policies and
stochastic culling), sampling (samplers against culling on one frame; reads
DIR/sampling.csv, app.bench.sampling), stereo (two eyes, a structure per view or one over
both frusta; reads DIR/stereo.csv, app.bench.stereo), transparent (the frame with its
transparent layers against the opaque-only frame; reads DIR/transparent.csv,
app.bench.transparent), fog (froxel light sets and the banding case; reads DIR/fog.csv and
DIR/fog_banding.npz, app.bench.fog).
"""
from __future__ import annotations

import json
import math
from pathlib import Path
import sys

import numpy as np

from ..results import option_specs, read_csv
from .accuracy import fig_accuracy
from .common import Colors, Roles, num, order, sel
from .cpu import fig_cpu
from .cutoff import EXPLANATION as CUTOFF_EXPLANATION, fig_cutoff
from .gpu import believe_text, fig_gpu_pareto, fig_gpu_scenes, fig_measured
from .maps import fig_classification, fig_heat, fig_own_maps
from .notes import technique_notes
from .options import fig_option, studied_options
from .path import fig_path, fig_path_cpu
from .temporal import CSV as TEMPORAL_CSV, EXPLANATION as TEMPORAL_EXPLANATION, fig_temporal
from .tables import floor_table, summary_table
from .tradeoff import EXPLANATION as TRADEOFF_EXPLANATION, fig_tradeoff
from .sampling import CSV as SAMPLING_CSV, sampling_section
from .stereo import CSV as STEREO_CSV, stereo_section
from .transparent import CSV as TRANSPARENT_CSV, transparent_section
from .fog import CSV as FOG_CSV, fog_section
from .model import model_section
from .runtime import time_lines as run_time_lines
from .validation import validation


def write_report(out: Path, rows: list[dict], maps: dict, info: dict) -> list[str]:
    """Write every plot and report.md into `out`; returns the PNG names."""
    out = Path(out)
    roles = Roles.from_registry()
    colors = Colors(order(rows, "technique"), roles)
    pngs: list[str] = []
    sections: list[str] = []

    def section(title, png, text, extra=""):
        if png is None and not text and not extra:
            return
        body = [f"## {title}", ""]
        if png:
            body += [f"![{title}]({png})", ""]
            pngs.append(png)
        body += [t if t.startswith(("|", "-")) else f"- {t}" for t in text]
        if extra:
            body += ["", extra]
        sections.append("\n".join(body) + "\n")

    trows = read_csv(out / TEMPORAL_CSV) if (out / TEMPORAL_CSV).exists() else []
    section("The whole accuracy trade-off: image error against frame cost",
            *fig_tradeoff(rows, trows, out, colors, roles), TRADEOFF_EXPLANATION)
    srows = read_csv(out / SAMPLING_CSV) if (out / SAMPLING_CSV).exists() else []
    section("Sampling against culling on one frame: error against evaluations and frame cost",
            *sampling_section(srows, out, roles))
    strows = read_csv(out / STEREO_CSV) if (out / STEREO_CSV).exists() else []
    section("Two eyes: a structure per view or one over both frusta", *stereo_section(strows))
    trrows = read_csv(out / TRANSPARENT_CSV) if (out / TRANSPARENT_CSV).exists() else []
    section("Transparent layers: each technique's frame with its layers against its opaque-only "
            "frame", *transparent_section(trrows, out))
    fgrows = read_csv(out / FOG_CSV) if (out / FOG_CSV).exists() else []
    section("Fog: froxel light sets from each technique's structure, and the banding case",
            *fog_section(fgrows, out))
    section("What accuracy costs: culling waste vs frame cost", *fig_accuracy(rows, out, colors, roles))
    section("Modelled GPU cost at 1920x1080, per scene and GPU (app/model)",
            *fig_gpu_scenes(rows, out, colors, roles))
    section("Culling waste against modelled GPU time: the Pareto front under each GPU",
            *fig_gpu_pareto(rows, out, colors, roles))
    section("The cost model: what it counts and what it assumes", None, *model_section(rows))
    vpng, vtext, vtables = validation(rows, out, colors)
    section("Validation: the cost model beside the papers' measurements", vpng, vtext, vtables)
    section("Measured on a real GPU against modelled", *fig_measured(rows, out, colors, info))
    section("GPU lighting time along the camera path (tree paper figure 7)",
            *fig_path(rows, out, colors, roles))
    section("The CPU stage's rebuild along the moving path", *fig_path_cpu(trows, out, colors, roles))
    ftable, ftext = floor_table(rows, roles)
    section(f"Shading time against the floor ({roles.floor})", None, ftext,
            f"Shading ms, mean over the path; in brackets the position between "
            f"{roles.reference} (0%) and {roles.floor} (100%).\n\n" + ftable)
    name, text, table = fig_cpu(rows, out)
    section("CPU stage vs light count (tree paper figure 4, 4.1)", name, text,
            "Share of each step, mean over the light counts (min-max in brackets):\n\n" + table
            if table else "")
    for opt, is_bool in studied_options(rows):
        spec = option_specs().get(opt)
        what = f" ({spec.help})" if spec else ""
        section(f"Option study: {opt}{what}", *fig_option(rows, opt, is_bool, out, colors))
    for title, text in technique_notes(rows):
        section(title, None, [], text)
    section("Lights evaluated per pixel (tree paper figure 1)", *fig_heat(maps, out, info, roles))
    section("Each technique's own structure (e.g. Mikkelsen figures 2.4-2.6)", *fig_own_maps(maps, out, info))
    section("Traversal per wave: list / tree / mixed (tree paper figure 3)",
            *fig_classification(rows, maps, out))
    section("The light cutoff: image error vs cost", *fig_cutoff(rows, out, colors, roles),
            CUTOFF_EXPLANATION)
    section("Temporal stability along a moving path: temporal error and popping",
            *fig_temporal(trows, out, colors, roles), TEMPORAL_EXPLANATION)
    sections.append("## Hardware-neutral figures (camera path, mean over frames)\n\n"
                    + summary_table(rows) + "\n")
    (out / "report.md").write_text("\n".join(_head(rows, info, roles)) + "\n" + "\n".join(sections))
    return pngs


def _head(rows, info, roles) -> list[str]:
    head = [
        "# Many-light culling benchmark", "",
        f"- command: `{info.get('command', '')}` (preset `{info.get('preset', '')}`)",
        f"- machine: {info.get('cpu', '?')}, {info.get('cores', '?')} cores; "
        f"{info.get('system', '')}, Python {info.get('python', '')}",
        f"- GL: {info.get('gl_renderer', '?')} ({info.get('gl_version', '')})" +
        (f"; clocks at the end of the run: {info['gpu_clocks']}" if info.get("gpu_clocks") else ""),
        f"- CPU stage: {info.get('cpu_threads', '?')} numba thread(s) (the paper's figure 4 is "
        f"single threaded)",
        f"- run time: {info.get('elapsed_s', 0):.0f} s; {len(rows)} rows in results.csv",
        *run_time_lines(info),
        "",
    ]
    head += believe_text(rows, info, roles)
    if info.get("software", False):
        head += ["> **Software rasterizer.** GPU passes were timed as wall clock around the "
                 "dispatch plus glFinish on a CPU rasterizer that shares the cores with the CPU "
                 "stage. GPU times here are only comparable as ratios between techniques within "
                 "this run, never as absolute GPU figures.", ""]
    else:
        head += ["GPU passes timed with GL timer queries.", ""]
    rendered = [r for r in rows if not math.isnan(num(r.get("mismatch_count")))]
    mism = sum(num(r["mismatch_count"]) + num(r["mismatch_hash"]) for r in rendered)
    samples = [int(num(r["samples"])) for r in rendered if not math.isnan(num(r.get("samples")))]
    head += [f"Exactness: {int(mism)} pixels differ from {roles.reference} in contrib_count or "
             f"contrib_hash over every rendered configuration (must be 0).  Columns and studies "
             f"are described in `app/results.py`, the timing method in `app/bench/sweep.py`; the "
             f"same command gives the same table apart from the timing columns (*_ms, "
             f"gpu_passes, floor_position_pct).", ""]
    if samples:
        head += [f"Timing samples per configuration: {min(samples)} to {max(samples)}.  A "
                 f"difference is called a finding (fastest, lowest, higher, lower) only when one "
                 f"side's slowest sample beats the other's fastest; otherwise the text says "
                 f"*within spread*.", ""]
    path = sel(rows, study="path")
    if path:
        r0 = path[0]
        defaults = ", ".join(f"{n} {s.default}" for n, s in option_specs().items())
        head += [f"Camera-path study at {int(r0['width'])}x{int(r0['height'])}, "
                 f"{int(r0['frames'])} frames along the path, every technique at its declared "
                 f"option defaults ({defaults}); frame cost = CPU stage (cull, sort, bin, build, "
                 f"pack, upload) + every timed GPU pass but the G-buffer (culling passes + "
                 f"shading); the floor ({roles.floor}) builds its exact lists in untimed set-up "
                 f"passes, so its cost is its CPU steps + shading.", ""]
    head += _modelled_rows(rendered)
    return head


def _modelled_rows(rendered) -> list[str]:
    """Which rendered rows have modelled GPU columns, where a preset leaves some out."""
    modelled = [r for r in rendered if not math.isnan(num(r.get("model_version")))]
    if len(modelled) == len(rendered):
        return []
    frames = sorted({int(num(r["frame"])) for r in modelled if r["study"] == "path"})
    left = sorted({r["study"] for r in rendered if r["study"] != "path"}
                  - {r["study"] for r in modelled})
    return [f"Modelled GPU columns (the wave replay): {len(modelled)} of the {len(rendered)} "
            f"rendered rows, those of path frame{'s' if len(frames) != 1 else ''} "
            f"{', '.join(map(str, frames)) or '(none)'} and of every other study"
            + (f" but {' and '.join(left)}" if left else "") +
            " (the preset's model_frames and unmodelled: no section here reads the others' on "
            "a software rasterizer).", ""]


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        raise SystemExit("usage: python -m app.report DIR")
    out = Path(argv[0])
    rows = read_csv(out / "results.csv")
    maps = dict(np.load(out / "maps.npz")) if (out / "maps.npz").exists() else {}
    info = json.loads((out / "run.json").read_text()) if (out / "run.json").exists() else {}
    write_report(out, rows, maps, info)


__all__ = ["write_report", "main"]
