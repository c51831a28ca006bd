"""The model held to a real GPU: the measured-against-modelled figures of one run's rows
(rank agreement, measured / modelled ratios), and the committed record of the last real-GPU
run (docs/gpu-check/: its results.csv and run.json, written by scripts/gpu_check.sh), which
the report cites where its own run had no GPU."""
from __future__ import annotations

from dataclasses import dataclass
import json
import math
from pathlib import Path

import numpy as np

from ..model import cost
from ..results import read_csv
from .common import gmean, num, sel

RECORD = Path(__file__).resolve().parents[2] / "docs" / "gpu-check"
TIE = 0.10           # measured or modelled times within 10% of each other are not ordered


def lighting(r, g) -> float:
    return num(r.get(f"model_{g.key}_lighting_ms"))


def rank_agreement(rows, g) -> tuple[int, int, int, int]:
    """(frames whose techniques the model orders as measured, frames, technique pairs the
    model orders as measured, pairs): a pair counts where its measured times differ by more
    than TIE; it is ordered alike unless the model puts it the other way by more than TIE."""
    frames: dict[tuple, list] = {}
    for r in rows:
        frames.setdefault((r["scene"], r["lights"], r["frame"]), []).append(r)
    same = pairs = alike = 0
    for group in frames.values():
        ok = True
        for a in group:
            for b in group:
                if num(a["gpu_lighting_ms"]) < (1 - TIE) * num(b["gpu_lighting_ms"]):
                    pairs += 1
                    right = not lighting(a, g) > (1 + TIE) * lighting(b, g)
                    alike += right
                    ok = ok and right
        same += ok
    return same, len(frames), alike, pairs


def pair_error(rows, g) -> float:
    """The median factor by which the model's ratio of two techniques' lighting times misses
    the measured ratio, over every pair of techniques in a frame (1: the ratios agree)."""
    frames: dict[tuple, list] = {}
    for r in rows:
        frames.setdefault((r["scene"], r["lights"], r["frame"]), []).append(r)
    logs = [abs(math.log(num(a["gpu_lighting_ms"]) / num(b["gpu_lighting_ms"]))
                - math.log(lighting(a, g) / lighting(b, g)))
            for group in frames.values() for i, a in enumerate(group) for b in group[i + 1:]
            if min(num(a["gpu_lighting_ms"]), num(b["gpu_lighting_ms"]),
                   lighting(a, g), lighting(b, g)) > 0]
    return math.exp(float(np.median(logs))) if logs else math.nan


def measured_rows(rows) -> list[dict]:
    """The path rows with both a measured and a modelled lighting time (a preset may model
    only the first frame of each path: app.bench.rendered's model_frames)."""
    return [r for r in sel(rows, study="path") if np.isfinite(num(r.get("gpu_lighting_ms")))
            and np.isfinite(num(r.get("model_version")))]


def model_of(renderer: str):
    """(the model's GPU for a renderer string, whether the model names it): an unnamed GPU
    is compared with the model's H200, its newest kind."""
    g = cost.match(renderer)
    return (g, True) if g is not None else (
        next((x for x in cost.GPUS if x.key == "h200"), cost.GPUS[0]), False)


def ratios(rows, g) -> dict[str, float]:
    """Per technique, the geometric mean of measured / modelled lighting ms."""
    out = {}
    for t in dict.fromkeys(r["technique"] for r in rows):
        tr = sel(rows, technique=t)
        m = np.array([num(r["gpu_lighting_ms"]) for r in tr])
        p = np.array([lighting(r, g) for r in tr])
        out[t] = gmean(m / np.maximum(p, 1e-9))
    return out


@dataclass(frozen=True)
class Record:
    renderer: str
    size: str
    lights: str
    model_version: str
    low: float                 # the smallest per-technique measured / modelled
    high: float
    alike: int                 # technique pairs the model orders as measured
    pairs: int
    pair_factor: float         # the median factor the model's ratio of two techniques misses by

    def sentence(self) -> str:
        stale = ("" if self.model_version == str(cost.MODEL_VERSION) else
                 f" (against model v{self.model_version}; this is v{cost.MODEL_VERSION})")
        return (f"the one real-GPU record, docs/gpu-check/ ({self.renderer}, {self.size}, "
                f"{self.lights} lights){stale}, measured {self.low:.3g}x to {self.high:.3g}x "
                f"the modelled lighting time per technique, and the model ordered {self.alike} "
                f"of the {self.pairs} technique pairs measured more than {TIE:.0%} apart as "
                f"measured, its ratio of two techniques' times off by a median factor of "
                f"{self.pair_factor:.2g}")


def record(folder: Path = RECORD) -> Record | None:
    """The committed real-GPU record, None where there is none (or it holds no GPU rows)."""
    try:
        info = json.loads((folder / "run.json").read_text())
        rows = measured_rows(read_csv(folder / "results.csv"))
    except (OSError, ValueError):
        return None
    if info.get("software", True) or not rows:
        return None
    g, _ = model_of(str(info.get("gl_renderer", "")))
    r = ratios(rows, g)
    _, _, alike, pairs = rank_agreement(rows, g)
    shared = info.get("config", {}).get("shared", {})
    size = "x".join(str(v) for v in shared.get("size", ())) or "?"
    lights = ", ".join(f"{n:,}" for n in shared.get("lights", ())) or "?"
    version = str(rows[0].get("model_version", "?")).split(".")[0]
    return Record(str(info.get("gl_renderer")), size, lights, version, min(r.values()),
                  max(r.values()), alike, pairs, pair_error(rows, g))


__all__ = ["RECORD", "TIE", "Record", "lighting", "measured_rows", "model_of", "pair_error",
           "rank_agreement",
           "ratios", "record"]
