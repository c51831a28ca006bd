"""One results.csv row from a rendered frame: timings over its samples, hardware-neutral
figures, bytes, and its error against the reference.  No technique is named here: the
frame cost of every technique (the floor included) is its CPU stage plus every timed GPU
pass but the frame's G-buffer; untimed set-up (the floor's list building) is no cost.
"""
from __future__ import annotations

import json
import math

import numpy as np

from ..pipeline import phases
from ..results import FRAME_PASS, STAGES, option_columns, stats


def samples_of(meta: dict) -> list[dict]:
    """Each timing sample {"cpu_ms", "gpu_ms"} of a render (one when samples=1)."""
    return list(meta.get("samples") or [{"cpu_ms": meta["cpu_ms"], "gpu_ms": meta["gpu_ms"]}])


def split_gpu(gpu_ms: dict) -> tuple[float, float, float]:
    """(gbuffer, cull, shade) ms of one sample: the frame's G-buffer pass; the technique's
    timed passes before its last; its last timed pass, the shading pass (a technique's
    passes end with it; passes of one name, e.g. the floor's bands, are summed by the timer)."""
    own = [v for k, v in gpu_ms.items() if k != FRAME_PASS]
    return float(gpu_ms.get(FRAME_PASS, 0.0)), float(sum(own[:-1])), float(own[-1] if own else 0.0)


def frame_cost(sample: dict) -> float:
    """CPU stage (upload included) + every timed GPU pass except the G-buffer."""
    _, cull, shade = split_gpu(sample["gpu_ms"])
    return float(sum(sample["cpu_ms"].values())) + cull + shade


def timing_cells(samples: list[dict]) -> dict:
    """The timing columns of a row: medians (and min/max) over the samples."""
    r = {}
    for k in STAGES:
        r[f"cpu_{k}_ms"] = stats(float(m["cpu_ms"].get(k, 0.0)) for m in samples)[0]
    r["cpu_total_ms"], r["cpu_total_min_ms"], r["cpu_total_max_ms"] = \
        stats(sum(m["cpu_ms"].values()) for m in samples)
    parts = [split_gpu(m["gpu_ms"]) for m in samples]
    for i, name in enumerate(("gbuffer", "cull", "shade")):
        r[f"gpu_{name}_ms"], r[f"gpu_{name}_min_ms"], r[f"gpu_{name}_max_ms"] = stats(p[i] for p in parts)
    r["gpu_lighting_ms"], r["gpu_lighting_min_ms"], r["gpu_lighting_max_ms"] = \
        stats(p[1] + p[2] for p in parts)
    r["frame_cost_ms"], r["frame_cost_min_ms"], r["frame_cost_max_ms"] = \
        stats(frame_cost(m) for m in samples)
    r["gpu_passes"] = ";".join("{}={:.3f}/{:.3f}/{:.3f}".format(k, *v)
                               for k, v in pass_stats(samples).items())
    r["samples"] = len(samples)
    return r


def pass_stats(samples: list[dict]) -> dict[str, tuple[float, float, float]]:
    """Each timed pass's (median, min, max) ms over the samples, in the frame's pass order
    (0 in a sample that lacks it)."""
    names = dict.fromkeys(k for m in samples for k in m["gpu_ms"])
    return {k: stats(m["gpu_ms"].get(k, 0.0) for m in samples) for k in names}


def option_cells(opts) -> dict:
    """Every option column: the technique's values, blank where it lacks the option."""
    cells = {c: "" for c in option_columns()}
    cells.update(opts.as_dict())
    return cells


def cpu_study_row(study: str, technique, scene_name: str, lights: int, visible: int, size,
                  samples: int, opts) -> dict:
    """The head of a results.csv row of a study of one frame's CPU build (frame 0 of the
    scene's 64-frame path, no cutoff): where, what and how many samples, every option
    column; the study adds its figures."""
    row = {"study": study, "scene": scene_name, "lights": int(lights), "visible": int(visible),
           "width": size[0], "height": size[1], "frame": 0, "frames": 64,
           "technique": technique.name, "role": technique.role, "cutoff": 0, "samples": samples}
    row.update(option_cells(opts))
    return row


def figure_cells(res) -> dict:
    """Hardware-neutral figures over geometry pixels, and the bytes the technique bound."""
    mask = res.depth > 0
    ev = res.evaluated[mask].astype(np.float64)
    ex = res.contrib_count[mask].astype(np.float64)
    nbytes = res.meta["bytes"]
    return {
        "evaluated_pp": float(ev.mean()) if mask.any() else 0.0,
        "exact_pp": float(ex.mean()) if mask.any() else 0.0,
        "waste": float(ev.sum() / ex.sum()) if ex.sum() > 0 else math.nan,
        "nodes_pp": float(res.nodes[mask].mean()) if mask.any() else 0.0,
        "wave_iters": float(res.wave["iterations"].mean()),
        "bytes_lights": int(nbytes.get("lights", 0)),
        "bytes_culling": int(sum(v for k, v in nbytes.items() if k != "lights")),
        "stats": json.dumps({k: v for k, v in res.meta["stats"].items()
                             if isinstance(v, (int, float)) and not isinstance(v, bool)},
                            sort_keys=True),
    }


def evaluated_per_pixel(res) -> float:
    mask = res.depth > 0
    return float(res.evaluated[mask].mean()) if mask.any() else 0.0


@phases.timed("check")            # app.pipeline.phases: where a run's time goes
def image_error(res, ref) -> float:
    """RMSE of linear radiance over geometry pixels, relative to the reference's mean."""
    mask = ref.depth > 0
    if not mask.any():
        return 0.0
    a = res.image[mask].astype(np.float64)
    b = ref.image[mask].astype(np.float64)
    mean = float(b.mean())
    rmse = float(np.sqrt(((a - b) ** 2).mean()))
    return rmse / mean if mean > 0 else rmse


@phases.timed("check")
def image_flip(res, ref) -> float:
    """Mean LDR FLIP (NVIDIA's perceptual difference metric, Andersson et al. 2020) between
    the tone-mapped images a user sees (app.images.tonemap, sRGB), over the whole frame."""
    import flip_evaluator
    from ..images import tonemap
    a = tonemap(ref.image)
    b = tonemap(res.image)
    if np.array_equal(a, b):
        return 0.0
    # exact techniques give one image for the same lights: the cutoff study's levels and the
    # caps series compare the same pair with the unbounded reference technique after
    # technique, each FLIP ~70 ms even at 64x36, so a pair's value is computed once
    key = (a.shape, _digest(a), _digest(b))
    if key not in _FLIP:
        if len(_FLIP) >= 4096:
            _FLIP.clear()
        _FLIP[key] = float(flip_evaluator.evaluate(a.astype(np.float32) / 255.0,
                                                   b.astype(np.float32) / 255.0, "LDR",
                                                   inputsRGB=True, applyMagma=False)[1])
    return _FLIP[key]


_FLIP: dict = {}       # (shape, digest of the reference's image, of the frame's) -> mean FLIP


def _digest(img: np.ndarray) -> bytes:
    import hashlib
    return hashlib.blake2b(np.ascontiguousarray(img).data, digest_size=16).digest()


@phases.timed("check")
def radiance_ratio(res, ref) -> float:
    """Mean linear radiance over the reference's geometry pixels, relative to the reference."""
    mask = ref.depth > 0
    b = float(ref.image[mask].astype(np.float64).mean()) if mask.any() else 0.0
    return float(res.image[mask].astype(np.float64).mean()) / b if b > 0 else 1.0


@phases.timed("check")
def mismatches(res, ref) -> tuple[int, int]:
    """Pixels whose contrib_count, contrib_hash differ from the reference's (a frame with
    transparent layers: those of every layer's pixels too, app/pipeline/transparent.py)."""
    count, hashes = (int((res.contrib_count != ref.contrib_count).sum()),
                     int((res.contrib_hash != ref.contrib_hash).sum()))
    if getattr(res, "contrib_count_t", None) is not None:
        count += int((res.contrib_count_t != ref.contrib_count_t).sum())
        hashes += int((res.contrib_hash_t != ref.contrib_hash_t).sum())
    return count, hashes


def fill_floor_positions(rows: list[dict], reference: str, floor: str) -> None:
    """Each path row's shading time as a position between the reference (0%) and the
    floor (100%) on the same frame."""
    by = {}
    for r in rows:
        if r["study"] == "path":
            by.setdefault((r["scene"], r["lights"], r["frame"]), {})[r["technique"]] = r
    for group in by.values():
        b, f = group.get(reference), group.get(floor)
        if b is None or f is None:
            continue
        span = b["gpu_shade_ms"] - f["gpu_shade_ms"]
        for r in group.values():
            r["floor_position_pct"] = 100.0 * (b["gpu_shade_ms"] - r["gpu_shade_ms"]) / span \
                if span > 0 else math.nan


def model_cells(figures: dict) -> dict:
    """The modelled GPU columns and the per-wave figures of a frame (app.model); none for a
    technique without a wave program (figures None)."""
    from ..model import cost, predict
    if figures is None:
        return {}
    r = {"model_version": cost.MODEL_VERSION}
    for key, m in predict.modelled(figures).items():
        r[f"model_{key}_cull_ms"], r[f"model_{key}_shade_ms"] = m["cull"], m["shade"]
        r[f"model_{key}_lighting_ms"] = m["cull"] + m["shade"]
        r[f"model_{key}_bound"] = m["bound"]
    for width, passes in figures.items():
        f = passes[predict.SHADE]
        issued = int(f.loops[:, 0].sum())
        loads = f.loop_sum("vector_loads") + f.loop_sum("scalar_loads")
        r[f"w{width}_issued_pw"] = issued / f.busy_waves if f.busy_waves else 0.0
        r[f"w{width}_simd"] = f.simd_use
        r[f"w{width}_lines_pi"] = (f.loop_sum("vector_lines") + f.loop_sum("scalar_lines")) / issued \
            if issued else 0.0
        r[f"w{width}_scalar_share"] = f.loop_sum("scalar_loads") / loads if loads else 0.0
    r["waves"] = json.dumps({str(w): {name: f.as_dict() for name, f in passes.items()}
                             for w, passes in figures.items()}, sort_keys=True)
    return r


def model_frame_cells(row: dict) -> dict:
    """model_<gpu>_frame_ms: this machine's measured CPU stage + the modelled lighting."""
    from ..model import cost
    return {f"model_{g.key}_frame_ms": row["cpu_total_ms"] + row[f"model_{g.key}_lighting_ms"]
            for g in cost.GPUS if f"model_{g.key}_lighting_ms" in row}
