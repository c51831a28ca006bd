"""The camera-path study summarised per (scene, light count) and technique: means over the
path frames (timings as Spreads), and the accuracy/cost Pareto front."""
from __future__ import annotations

import math

from .common import mean, num, order, sel
from .spread import Spread


def aggregate_path(rows) -> dict:
    """{(scene, lights): {technique: dict(cost, cpu, gpu, shade: Spread; waste, ...)}}."""
    out = {}
    path = sel(rows, study="path")
    for sc in order(path, "scene"):
        for n in sorted(set(int(r["lights"]) for r in sel(path, scene=sc))):
            sub = sel(path, scene=sc, lights=float(n))
            d = {}
            for t in order(sub, "technique"):
                tr = sel(sub, technique=t)
                ev = sum(num(r["evaluated_pp"]) for r in tr)
                ex = sum(num(r["exact_pp"]) for r in tr)
                d[t] = dict(cost=Spread.mean(Spread.of(r, "frame_cost") for r in tr),
                            cpu=Spread.mean(Spread.of(r, "cpu_total") for r in tr),
                            gpu=Spread.mean(Spread.of(r, "gpu_lighting") for r in tr),
                            shade=Spread.mean(Spread.of(r, "gpu_shade") for r in tr),
                            waste=ev / ex if ex > 0 else math.nan,
                            evaluated=mean([r["evaluated_pp"] for r in tr]),
                            exact=mean([r["exact_pp"] for r in tr]),
                            nodes=mean([r["nodes_pp"] for r in tr]),
                            iters=mean([r["wave_iters"] for r in tr]),
                            bytes=mean([r["bytes_culling"] for r in tr]),
                            mism=sum(num(r["mismatch_count"]) + num(r["mismatch_hash"]) for r in tr),
                            err=max(num(r["image_error"]) for r in tr))
            out[(sc, n)] = d
    return out


def pareto(points: dict) -> list:
    """Names on the front of (cost, waste), both minimised, cheapest first."""
    front, best = [], math.inf
    for t in sorted(points, key=lambda t: (points[t][0], points[t][1])):
        if points[t][1] < best:
            front.append(t)
            best = points[t][1]
    return front
