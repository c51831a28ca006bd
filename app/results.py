"""The benchmark's results table (results.csv): its columns, its studies, reading and writing
it, and the median/min/max of repeated samples.  app.bench writes it, app.report reads it;
neither knows the other's internals, only this schema.

One row is one measured configuration (a rendered frame, or a CPU-stage-only series point):

    study, scene, lights, visible, width, height, frame, frames, technique, role
    <one column per technique option>   the union of the registry's option names, blank
                                        where the row's technique does not take the option
    cutoff, samples                     light cutoff 1/t (0: the scene's radii, -1: the
                                        unbounded reference); timing samples of the row
    cpu_<stage>_ms                      median of each CPU step (cull sort bin build pack
                                        upload); cpu_total_ms with its _min_ / _max_
    gpu_<part>_ms                       gbuffer (the frame's own pass), cull (every timed
                                        pass of the technique before its last), shade (its
                                        last timed pass: the shading pass), lighting (cull +
                                        shade), each with _min_ / _max_ over the samples
    frame_cost_ms                       per sample: CPU total + every timed GPU pass except
                                        the G-buffer; median, _min_, _max_
    setup_ms                            untimed set-up (e.g. the floor's list building): not
                                        part of any cost
    evaluated_pp ... floor_position_pct hardware-neutral figures and exactness
    model_version                       the GPU cost model's version (app.model.cost)
    model_<gpu>_cull_ms, _shade_ms,     modelled on each named GPU (app.model.cost.GPUS):
      _lighting_ms, _frame_ms, _bound   culling passes, shading pass, both; frame = this
                                        machine's measured CPU stage + modelled lighting;
                                        the limit that bounds the shading pass
    w<W>_issued_pw, _simd, _lines_pi,   the shading pass's per-wave figures at W = 32 and 64
      _scalar_share                     lanes (app.model.waves): issued iterations per busy
                                        wave, SIMD use, distinct 64-B lines per issued
                                        iteration, share of its loads that are scalar
    waves                               every pass's full figures per width, as JSON

Studies (column `study`):
    path        every technique, every scene, light count and camera-path frame
    paper_<name> the papers' own settings (1920x1080), modelled only (app.bench.validation):
                paper_fig7, paper_zbin_table, paper_fptl, paper_fptl_visible, paper_scenes,
                and with --full paper_cluster_raster, paper_cluster_tile
    <option>    one per technique option that declares study values (OptionSpec.study): its
                values, over the techniques that declare it, on the study scene (frame 0)
    <option>@<scene>  the same in a scene of its own (OptionSpec.also_study), read by the
                technique's notes (raster_variant@contention)
    cutoff      the light cutoff against an unbounded reference, every technique (with
                stochastic culling's budgets where the preset asks: app.bench.cutoff)
    caps        the list techniques under each engine cap policy that drops lights in
                the caps scene (app.bench.caps): cost, image error, the intended loss
    temporal    consecutive frames of a path with moving lights (app.bench.temporal):
                temporal error and popping against the unbounded reference
    growth      the CPU stage alone from 8,192 doubling to 1,048,576 lights, one and two
                threads, each build's buffer bytes in stats (app.bench.cpu --growth)
    gpu_build   each technique that takes --build, built on the CPU and on the GPU at each
                light count (app.bench.gpu_build): the CPU stage's columns, the GPU build's
                ms, its passes and the ratio in stats
    cpu         the CPU stage alone (technique.build + upload) at the CPU series' resolution
    cpu_<option> the CPU stage alone over an option study's values at the CPU series'
                resolution (only when it differs from the rendered one); never to be added
                to GPU times measured at another resolution
"""
from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from .model.cost import GPUS
from .model.waves import WIDTHS
from .techniques import REGISTRY
from .techniques.options import CPU_PREFIX, OptionSpec, all_specs

CPU_STAGES = ("cull", "sort", "bin", "build", "pack")
UPLOAD = "upload"
STAGES = CPU_STAGES + (UPLOAD,)
FRAME_PASS = "gbuffer"         # the frame's own pass (app.pipeline.gbuffer), not a technique's
GPU_PARTS = ("gbuffer", "cull", "shade", "lighting")
FIXED_STUDIES = ("path", "cutoff", "cpu")
PAPER_PREFIX = "paper_"        # paper_<name>: the papers' settings, modelled (app.bench.validation)

_HEAD = ["study", "scene", "lights", "visible", "width", "height", "frame", "frames",
         "technique", "role"]
_TAIL = [
    "cutoff", "samples",
    *[f"cpu_{k}_ms" for k in STAGES], "cpu_total_ms", "cpu_total_min_ms", "cpu_total_max_ms",
    *[f"gpu_{p}{s}_ms" for p in GPU_PARTS for s in ("", "_min", "_max")], "gpu_passes",
    "frame_cost_ms", "frame_cost_min_ms", "frame_cost_max_ms", "setup_ms",
    "evaluated_pp", "exact_pp", "waste", "nodes_pp", "wave_iters",
    "bytes_lights", "bytes_culling", "error_ref", "image_error", "image_flip", "radiance_ratio",
    "mismatch_count", "mismatch_hash", "floor_position_pct", "stats",
    "model_version",
    *[f"model_{g.key}_{k}" for g in GPUS for k in ("cull_ms", "shade_ms", "lighting_ms", "frame_ms", "bound")],
    *[f"w{w}_{k}" for w in WIDTHS for k in ("issued_pw", "simd", "lines_pi", "scalar_share")],
    "waves",
]
TEXT_COLUMNS = {"study", "scene", "technique", "role", "gpu_passes", "error_ref", "stats",
                "model_version", "waves", *(f"model_{g.key}_bound" for g in GPUS)}
# stats: the technique's numeric meta stats of the frame, as JSON; waves: app.model figures


def option_specs() -> dict[str, OptionSpec]:
    """{option name: spec} over every registered technique, in declaration order."""
    return all_specs(t.Options for t in REGISTRY.values())


def option_columns() -> list[str]:
    """The CSV's option columns: the union of the registry's option names."""
    return list(option_specs())


def option_studies() -> dict[str, tuple[OptionSpec, tuple[str, ...]]]:
    """{study name (= option name): (its spec, the techniques declaring it)} for every
    option with study values; no hand-kept list."""
    out = {}
    for name, spec in option_specs().items():
        if not spec.study:
            continue
        if name in FIXED_STUDIES or name in _HEAD or name in _TAIL:
            raise ValueError(f"option '{name}' clashes with a results.csv study or column")
        out[name] = (spec, tuple(t.name for t in REGISTRY.values() if name in t.Options.names()))
    return out


def columns() -> list[str]:
    """Every column of results.csv, in order (the option columns from the registry)."""
    return _HEAD + option_columns() + _TAIL


def timing_columns() -> set[str]:
    """Columns that change from run to run of the same command (everything else must not)."""
    return {c for c in columns() if c.endswith("_ms")} | {"gpu_passes", "floor_position_pct"}


def stats(values) -> tuple[float, float, float]:
    """(median, min, max) of samples; NaNs where there are none."""
    a = np.asarray(list(values), np.float64)
    return (float(np.median(a)), float(a.min()), float(a.max())) if len(a) else (math.nan,) * 3


def _fmt(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if math.isnan(v):
            return ""
        return f"{v:.4f}" if abs(v) < 1e6 else f"{v:.6g}"
    return str(v)


def write_csv(rows: list[dict], path: Path, cols: list[str] | None = None) -> None:
    """rows as results.csv (missing cells blank, booleans 0/1, floats to 4 decimals)."""
    cols = cols or columns()
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, cols, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({c: _fmt(r.get(c, "")) for c in cols})


def read_csv(path: Path) -> list[dict]:
    """Rows of results.csv with numbers parsed (empty cells: NaN), text columns as text."""
    out = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            d = {}
            for k, v in r.items():
                if k in TEXT_COLUMNS:
                    d[k] = v
                else:
                    try:
                        d[k] = float(v) if v != "" else math.nan
                    except ValueError:
                        d[k] = v
            out.append(d)
    return out


__all__ = ["CPU_STAGES", "UPLOAD", "STAGES", "FRAME_PASS", "GPU_PARTS", "FIXED_STUDIES",
           "CPU_PREFIX", "TEXT_COLUMNS", "option_specs", "option_columns", "option_studies",
           "columns", "timing_columns", "stats", "write_csv", "read_csv"]
