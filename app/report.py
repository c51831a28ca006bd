"""The benchmark's report: PNG plots (matplotlib Agg) and report.md, from results.csv.

    python -m app.report DIR       rebuild DIR/report.md and its plots from DIR/results.csv,
                                   DIR/maps.npz and DIR/run.json (no rendering)

Every sentence that reads a plot is generated from the numbers of this run.  Techniques are
iterated in the order they appear in the table (the registry's order), never named here: a
technique added to the registry appears in every plot and table.  The two roles the report
does know are the exactness reference and the perfect culler (app.bench.REFERENCE, PERFECT).
"""
from __future__ import annotations

import json
import math
from pathlib import Path
import sys

import numpy as np

from .bench import CPU_STAGES, PAPER_SHARES, PERFECT, REFERENCE, UPLOAD, read_csv

DPI = 80
STAGES = CPU_STAGES + (UPLOAD,)


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _side_legend(ax, *handles_labels, fontsize=7) -> None:
    """The legend outside the panel grid, right of its top-right panel."""
    ax.legend(*handles_labels, fontsize=fontsize, loc="upper left", bbox_to_anchor=(1.02, 1.0))


def _save(fig, out, name: str, tight: bool = True) -> str:
    """Lay out, write out/name and free the figure; returns the file name."""
    if tight:
        fig.tight_layout()
    fig.savefig(out / name)
    _plt().close(fig)
    return name


# ---------------------------------------------------------------------------- table helpers

def _order(rows, key):
    seen = []
    for r in rows:
        if r[key] not in seen:
            seen.append(r[key])
    return seen


def _sel(rows, **kw):
    return [r for r in rows if all(r.get(k) == v for k, v in kw.items())]


def _num(v) -> float:
    try:
        v = float(v)
    except (TypeError, ValueError):
        return math.nan
    return v


def _gmean(values) -> float:
    a = np.maximum(np.asarray([_num(v) for v in values], np.float64), 1e-6)
    return float(np.exp(np.log(a).mean())) if len(a) else math.nan


def _mean(values) -> float:
    a = np.asarray([_num(v) for v in values], np.float64)
    a = a[~np.isnan(a)]
    return float(a.mean()) if len(a) else math.nan


def _ms(v) -> str:
    v = _num(v)
    if math.isnan(v):
        return "-"
    return f"{v:.3g} ms" if v < 100 else f"{v:.0f} ms"


def _x(v) -> str:
    v = _num(v)
    return "-" if math.isnan(v) else (f"{v:.3g}x" if v < 100 else f"{v:.0f}x")


def _lighting(r) -> float:
    """GPU lighting time of a row: culling prepasses + shading (tree paper figure 7)."""
    return _num(r["gpu_cull_ms"]) + _num(r["gpu_shade_ms"])


def _log_axes(ax, x=True, y=True) -> None:
    """Log scale with plain tick labels at 1, 2, 5 x 10^k (no overlapping minor labels)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    fmt = FuncFormatter(lambda v, _: f"{v:g}")
    for on, axis, setter, lim in ((x, ax.xaxis, ax.set_xscale, ax.get_xlim),
                                  (y, ax.yaxis, ax.set_yscale, ax.get_ylim)):
        if not on:
            continue
        setter("log")
        ax.autoscale_view()
        lo, hi = sorted(lim())
        narrow = lo > 0 and hi / lo < 4       # less than a factor 4: label every 1..9 x 10^k
        axis.set_major_locator(LogLocator(base=10, subs=tuple(float(k) for k in range(1, 10))
                                          if narrow else (1.0, 2.0, 5.0)))
        axis.set_major_formatter(fmt)
        axis.set_minor_formatter(NullFormatter())


class Colors:
    def __init__(self, techniques):
        import matplotlib
        cmap = matplotlib.colormaps["tab10"]
        others = [t for t in techniques if t != PERFECT]
        self.c = {t: cmap(i % 10) for i, t in enumerate(others)}
        self.c[PERFECT] = (0, 0, 0, 1)

    def __call__(self, t):
        return self.c.get(t, (0.5, 0.5, 0.5, 1))

    @staticmethod
    def style(t):
        return dict(ls="--", marker="*") if t == PERFECT else dict(ls="-", marker="o")


# ---------------------------------------------------------------------------- the figures

def fig_path(rows, out, colors) -> tuple[str, list[str]]:
    """Tree paper figure 7: GPU lighting time per frame along the camera path."""
    plt = _plt()
    path = _sel(rows, study="path")
    scenes, counts = _order(path, "scene"), sorted(set(int(r["lights"]) for r in path))
    fig, axes = plt.subplots(len(scenes), len(counts), squeeze=False, dpi=DPI,
                             figsize=(4.2 * len(counts) + 1.6, 2.7 * len(scenes) + 0.4))
    text = []
    for i, sc in enumerate(scenes):
        for j, n in enumerate(counts):
            ax = axes[i][j]
            sub = _sel(path, scene=sc, lights=float(n))
            techs = _order(sub, "technique")
            gm = {}
            for t in techs:
                tr = sorted(_sel(sub, technique=t), key=lambda r: r["frame"])
                if not tr:
                    continue
                y = [_lighting(r) for r in tr]
                gm[t] = _gmean(y)
                ax.plot([r["frame"] for r in tr], y, color=colors(t), lw=1.3, ms=3,
                        label=t, **colors.style(t))
            _log_axes(ax, x=False)
            ax.set_title(f"{sc}, {n} lights", fontsize=9)
            ax.set_xlabel("camera path frame", fontsize=8)
            ax.set_ylabel("GPU cull + shade (ms)", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3, which="both")
            cands = {t: v for t, v in gm.items() if t != PERFECT}
            if not cands:
                continue
            rank = sorted(cands, key=cands.get)
            best = rank[0]
            s = f"**{sc}, {n} lights**: fastest over the path (geometric mean) is **{best}** " \
                f"({_ms(cands[best])}"
            if len(rank) > 1:
                s += f", {_x(cands[rank[1]] / cands[best])} ahead of {rank[1]}"
            if REFERENCE in cands and best != REFERENCE:
                s += f", {_x(cands[REFERENCE] / cands[best])} ahead of {REFERENCE}"
            s += ")"
            if PERFECT in gm:
                s += f"; the perfect culler's floor is {_ms(gm[PERFECT])}, " \
                     f"{_x(cands[best] / gm[PERFECT])} below it"
            spread = {}
            for t in rank:
                y = [_lighting(r) for r in _sel(sub, technique=t)]
                if len(y) > 1 and min(y) > 0:
                    spread[t] = (min(y), max(y))
            if spread:
                worst = max(spread, key=lambda t: spread[t][1] / spread[t][0])
                steady = min(spread, key=lambda t: spread[t][1] / spread[t][0])
                s += f". Along the path {worst} varies most ({_ms(spread[worst][0])} to " \
                     f"{_ms(spread[worst][1])}), {steady} least ({_ms(spread[steady][0])} to " \
                     f"{_ms(spread[steady][1])})"
            text.append(s + ".")
    _side_legend(axes[0][-1])
    name = _save(fig, out, "gpu_path.png")
    return name, text


def stage_shares(cpu_rows) -> dict:
    """{technique: {stage: (mean share %, min, max over light counts)}} of the CPU series."""
    out = {}
    for t in _order(cpu_rows, "technique"):
        shares = {k: [] for k in STAGES}
        for r in _sel(cpu_rows, technique=t):
            tot = sum(_num(r[f"cpu_{k}_ms"]) for k in STAGES)
            if tot > 0:
                for k in STAGES:
                    shares[k].append(100.0 * _num(r[f"cpu_{k}_ms"]) / tot)
        out[t] = {k: (float(np.mean(v)), float(np.min(v)), float(np.max(v))) if v else (0, 0, 0)
                  for k, v in shares.items()}
    return out


def fig_cpu(rows, out, colors) -> tuple[str | None, list[str], str]:
    """Tree paper figure 4: CPU stage time vs light count, stacked by stage."""
    plt = _plt()
    cpu = _sel(rows, study="cpu")
    if not cpu:
        return None, [], ""
    techs = _order(cpu, "technique")
    counts = sorted(set(int(r["lights"]) for r in cpu))
    fig, axes = plt.subplots(1, len(techs), squeeze=False, dpi=DPI, sharey=True,
                             figsize=(2.5 * len(techs) + 1.4, 3.3))
    stage_colors = dict(zip(STAGES, ("#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860")))
    for j, t in enumerate(techs):
        ax = axes[0][j]
        bottom = np.zeros(len(counts))
        for k in STAGES:
            v = np.array([_num(_sel(cpu, technique=t, lights=float(n))[0][f"cpu_{k}_ms"]) for n in counts])
            ax.bar(range(len(counts)), v, bottom=bottom, color=stage_colors[k], label=k)
            bottom += v
        ax.set_xticks(range(len(counts)), [f"{n // 1024}k" if n >= 1024 else str(n) for n in counts],
                      fontsize=7)
        ax.set_title(t, fontsize=9)
        ax.set_xlabel("lights", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3, axis="y")
    axes[0][0].set_ylabel("CPU ms (median)", fontsize=8)
    _side_legend(axes[0][-1])
    r0 = cpu[0]
    fig.suptitle(f"CPU stage, {r0['scene']} at {int(r0['width'])}x{int(r0['height'])}", fontsize=9)
    name = _save(fig, out, "cpu_stages.png")

    text, lo, hi = [], counts[0], counts[-1]
    totals = {t: {n: sum(_num(_sel(cpu, technique=t, lights=float(n))[0][f"cpu_{k}_ms"]) for k in STAGES)
                  for n in counts} for t in techs}
    if hi > lo:
        growth = ", ".join(f"{t} {_ms(totals[t][lo])} -> {_ms(totals[t][hi])} "
                           f"({_x(totals[t][hi] / max(totals[t][lo], 1e-9))})" for t in techs)
        text.append(f"From {lo} to {hi} lights ({_x(hi / lo)} the lights) the CPU stage grows: "
                    f"{growth}.")
    under = [t for t in techs if all(totals[t][n] < 2.0 for n in counts if n <= 8192)]
    if any(n <= 8192 for n in counts):
        who = ("every technique stays" if len(under) == len(techs) else
               f"{', '.join(under)} {'stays' if len(under) == 1 else 'stay'}" if under else
               "no technique stays")
        text.append(f"At 8192 lights or fewer {who} under 2 ms (the paper: every technique "
                    f"under 2 ms there, single threaded on an i7-4790K).")
    shares = stage_shares(cpu)
    table = ["| technique | " + " | ".join(STAGES) + f" | total at {hi} lights |",
             "|---" * (len(STAGES) + 2) + "|"]
    for t in techs:
        cells = [f"{shares[t][k][0]:.0f}% ({shares[t][k][1]:.0f}-{shares[t][k][2]:.0f})" for k in STAGES]
        table.append(f"| {t} | " + " | ".join(cells) + f" | {_ms(totals[t][hi])} |")
    table.append("| *paper, tree (i7-4790K)* | " + " | ".join(
        f"*{PAPER_SHARES[k]:.0f}%*" if k in PAPER_SHARES else "-" for k in STAGES) + " | - |")
    # the techniques whose CPU stage has the paper's steps (a build step): compare
    full = [t for t in techs if shares[t]["build"][0] > 0 and shares[t]["bin"][0] > 0]
    for t in full:
        top = max(STAGES, key=lambda k: shares[t][k][0])
        text.append(f"{t}: the largest step is {top} ({shares[t][top][0]:.0f}%); binning takes "
                    f"{shares[t]['bin'][0]:.0f}% (paper 50%), building {shares[t]['build'][0]:.0f}% "
                    f"(paper 25%), sorting {shares[t]['sort'][0]:.0f}% (12%), upload "
                    f"{shares[t]['upload'][0]:.0f}% (7%), culling {shares[t]['cull'][0]:.0f}% (3%).")
    return name, text, "\n".join(table)


def fig_tile(rows, out, colors) -> tuple[str | None, list[str]]:
    """Tree paper figure 6: CPU and GPU cost vs tile size."""
    plt = _plt()
    tile = _sel(rows, study="tile")
    if not tile:
        return None, []
    techs = _order(tile, "technique")
    cpu_rows = _sel(rows, study="cpu_tile")      # the CPU stage at the CPU series' resolution
    fig, axes = plt.subplots(1, 3, dpi=DPI, figsize=(12, 3.2))
    text = []
    for t in techs:
        tr = sorted(_sel(tile, technique=t), key=lambda r: r["tile"])
        x = [int(r["tile"]) for r in tr]
        ct = {int(r["tile"]): _num(r["cpu_total_ms"]) for r in _sel(cpu_rows, technique=t)}
        cpu = [ct.get(v, _num(r["cpu_total_ms"])) for v, r in zip(x, tr)]
        gpu = [_lighting(r) for r in tr]
        both = [a + b for a, b in zip(cpu, gpu)]
        for ax, y in zip(axes, (cpu, gpu, both)):
            ax.plot(x, y, color=colors(t), label=t, **colors.style(t))
        bg, bb = x[int(np.argmin(gpu))], x[int(np.argmin(both))]
        text.append(f"{t}: GPU lighting is lowest at {bg} px tiles ({_ms(min(gpu))}, "
                    f"{_ms(max(gpu))} at worst); CPU goes from {_ms(cpu[0])} at {x[0]} px to "
                    f"{_ms(cpu[-1])} at {x[-1]} px; CPU + GPU is lowest at {bb} px.")
    r0 = tile[0]
    cpu_res = (f"{int(cpu_rows[0]['width'])}x{int(cpu_rows[0]['height'])}" if cpu_rows else
               f"{int(r0['width'])}x{int(r0['height'])}")
    gpu_res = f"{int(r0['width'])}x{int(r0['height'])}"
    for ax, title in zip(axes, (f"CPU stage at {cpu_res} (ms)", f"GPU cull + shade at {gpu_res} (ms)",
                                "CPU + GPU (ms)")):
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("tile size (px)", fontsize=8)
        ax.set_xticks(sorted(set(int(r["tile"]) for r in tile)))
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[-1].legend(fontsize=7)
    fig.suptitle(f"tile size, {r0['scene']}, {int(r0['lights'])} lights, frame {int(r0['frame'])}",
                 fontsize=9)
    if int(r0["width"]) < 1920:
        k = 1920 / int(r0["width"])
        text.append(f"The GPU passes ran at {gpu_res}: there a {int(min(x))} px tile covers the share "
                    f"of the image a {int(min(x) * k)} px tile covers at 1920x1080, so the GPU optimum "
                    f"sits at a smaller tile than the paper's 48 px; the CPU stage ran at {cpu_res}.")
    name = _save(fig, out, "tile_size.png")
    return name, text


def fig_heat(rows, maps, out, info) -> tuple[str | None, list[str]]:
    """Tree paper figure 1: lights evaluated per 16x16 block, all techniques, one frame."""
    plt = _plt()
    from matplotlib.colors import LogNorm
    keys = [k for k in maps if k.startswith("evaluated/")]
    if not keys:
        return None, []
    panels = [(k.split("/", 1)[1], maps[k]) for k in keys]
    if "exact" in maps and f"evaluated/{PERFECT}" not in maps:
        panels.append(("exact (lights affecting)", maps["exact"]))
    vals = np.concatenate([m.ravel() for _, m in panels])
    pos = vals[vals > 0]
    vmin = max(float(pos.min()) if len(pos) else 0.1, 0.1)
    vmax = max(float(vals.max()), vmin * 10)
    cols = min(3, len(panels))
    rws = math.ceil(len(panels) / cols)
    h, w = panels[0][1].shape
    fig, axes = plt.subplots(rws, cols, squeeze=False, dpi=DPI,
                             figsize=(cols * 3.4 + 0.8, rws * 3.4 * h / w + 0.6))
    im = None
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (t, m) in zip(axes.ravel(), panels):
        im = ax.imshow(np.maximum(m, vmin), cmap="turbo", norm=LogNorm(vmin, vmax),
                       interpolation="nearest")
        ax.set_title(f"{t}: {m.mean():.3g}/px", fontsize=8)
    fig.colorbar(im, ax=axes.ravel().tolist(), shrink=0.8).set_label("lights / pixel (log)", fontsize=8)
    scene = info.get("config", {}).get("heat_scene", "")
    b = int(maps.get("block", 16))
    fig.suptitle(f"lights evaluated per pixel, {b}x{b} block means, {scene} frame 0", fontsize=9)
    name = _save(fig, out, "heatmaps.png", tight=False)
    means = {t: float(m.mean()) for t, m in panels}
    exact = float(maps["exact"].mean()) if "exact" in maps else math.nan
    ranked = sorted((t for t, _ in panels[:len(keys)] if t != PERFECT), key=means.get)
    text = ["On this frame the loop evaluates, per pixel on average: " +
            ", ".join(f"{t} {means[t]:.3g}" for t in ranked) +
            (f"; {exact:.3g} lights actually affect a pixel." if not math.isnan(exact) else ".")]
    if len(ranked) > 1 and not math.isnan(exact) and exact > 0:
        text.append(f"The tightest structure, {ranked[0]}, evaluates {_x(means[ranked[0]] / exact)} "
                    f"the exact count; {ranked[-1]} evaluates {_x(means[ranked[-1]] / exact)}.")
    return name, text


def fig_classification(rows, maps, out) -> tuple[str | None, list[str]]:
    """Tree paper figure 3, for every technique whose waves take more than one path: per 8x8
    wave, list (blue), tree (green), mixed (white), empty (grey)."""
    plt = _plt()
    from matplotlib.patches import Patch
    from .images import CASE_COLORS, CASE_NAMES
    path = _sel(rows, study="path")
    if not path:
        return None, []
    w, h = int(path[0]["width"]), int(path[0]["height"])
    chosen = []
    for k in [k for k in maps if k.startswith("cases/")]:
        cases = maps[k]
        if len(np.unique(cases[cases > 0])) >= 2:
            chosen.append((k.split("/", 1)[1], cases))
    if not chosen:
        return None, []
    fig, axes = plt.subplots(1, len(chosen), squeeze=False, dpi=DPI,
                             figsize=(4.2 * len(chosen) + 1.8, 4.2 * h / w + 0.7))
    text = []
    for ax, (t, cases) in zip(axes[0], chosen):
        rgb = np.zeros(cases.shape + (3,), np.uint8)
        for k, c in CASE_COLORS.items():
            rgb[cases == k] = c
        ax.imshow(np.repeat(np.repeat(rgb, 8, 0), 8, 1)[:h, :w], interpolation="nearest")
        ax.set_xticks([]), ax.set_yticks([])
        ax.set_title(f"{t}: traversal per 8x8 wave", fontsize=9)
        shares = {CASE_NAMES[k]: float((cases == k).mean()) for k in CASE_COLORS}
        busy = 1.0 - shares["empty"]
        text.append(f"{t}: of the waves that shade, " + ", ".join(
            f"{shares[n] / busy:.0%} {n}" for n in ("list", "tree", "mixed")) +
            (f" ({shares['empty']:.0%} of all waves are empty)." if busy > 0 else "."))
    axes[0][-1].legend(handles=[Patch(facecolor=np.array(CASE_COLORS[k]) / 255, edgecolor="0.5",
                                      label=CASE_NAMES[k]) for k in (1, 2, 3, 0)],
                       fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    name = _save(fig, out, "classification.png")
    return name, text


def aggregate_path(rows) -> dict:
    """{(scene, lights): {technique: dict(cost, waste, shade, ...)}} over the path frames."""
    out = {}
    path = _sel(rows, study="path")
    for sc in _order(path, "scene"):
        for n in sorted(set(int(r["lights"]) for r in _sel(path, scene=sc))):
            sub = _sel(path, scene=sc, lights=float(n))
            d = {}
            for t in _order(sub, "technique"):
                tr = _sel(sub, technique=t)
                ev = sum(_num(r["evaluated_pp"]) for r in tr)
                ex = sum(_num(r["exact_pp"]) for r in tr)
                d[t] = dict(cost=_mean([r["frame_cost_ms"] for r in tr]),
                            cpu=_mean([r["cpu_total_ms"] for r in tr]),
                            gpu=_mean([_lighting(r) for r in tr]),
                            shade=_mean([r["gpu_shade_ms"] for r in tr]),
                            waste=ev / ex if ex > 0 else math.nan,
                            evaluated=_mean([r["evaluated_pp"] for r in tr]),
                            exact=_mean([r["exact_pp"] for r in tr]),
                            nodes=_mean([r["nodes_pp"] for r in tr]),
                            iters=_mean([r["wave_iters"] for r in tr]),
                            bytes=_mean([r["bytes_culling"] for r in tr]),
                            mism=sum(_num(r["mismatch_count"]) + _num(r["mismatch_hash"]) for r in tr),
                            err=max(_num(r["image_error"]) for r in tr))
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


def fig_accuracy(rows, out, colors) -> tuple[str | None, list[str]]:
    """The headline: culling accuracy (lights evaluated per exact light) vs frame cost."""
    plt = _plt()
    agg = aggregate_path(rows)
    if not agg:
        return None, []
    keys = list(agg)
    cols = min(2, len(keys))
    rws = math.ceil(len(keys) / cols)
    fig, axes = plt.subplots(rws, cols, squeeze=False, dpi=DPI, figsize=(5.2 * cols + 1.4, 3.6 * rws))
    for ax in axes.ravel()[len(keys):]:
        ax.axis("off")
    text = []
    for ax, key in zip(axes.ravel(), keys):
        d = agg[key]
        pts = {t: (v["cost"], v["waste"]) for t, v in d.items()
               if t != PERFECT and not math.isnan(v["waste"])}
        for t, v in d.items():
            if math.isnan(v["waste"]):
                continue
            ax.scatter([v["cost"]], [v["waste"]], color=colors(t), s=90 if t == PERFECT else 40,
                       marker="*" if t == PERFECT else "o", zorder=3, label=t)
            ax.annotate(t, (v["cost"], v["waste"]), fontsize=7, xytext=(4, 3),
                        textcoords="offset points")
        front = pareto(pts)
        if front:
            ax.step([pts[t][0] for t in front], [pts[t][1] for t in front], where="post",
                    color="0.4", lw=1, ls=":", zorder=2, label="Pareto front")
        _log_axes(ax)
        ax.set_xlabel("frame cost: CPU stage + GPU cull + shade (ms, mean over path)", fontsize=7)
        ax.set_ylabel("lights evaluated / lights affecting", fontsize=7)
        ax.set_title(f"{key[0]}, {key[1]} lights", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3, which="both")
        if not front:
            continue
        s = f"**{key[0]}, {key[1]} lights**: the Pareto front is " + " -> ".join(
            f"{t} ({_ms(pts[t][0])}, waste {pts[t][1]:.3g})" for t in front)
        off = [t for t in pts if t not in front]
        if off:
            s += "; " + ", ".join(f"{t} is dominated by " + next(
                f for f in front if pts[f][0] <= pts[t][0] and pts[f][1] <= pts[t][1]) for t in off)
        if PERFECT in d:
            s += f". The perfect culler would cost {_ms(d[PERFECT]['cost'])} (the shared CPU steps + " \
                 f"shading over exact lists built untimed)"
        text.append(s + ".")
    handles, labels = axes[0][0].get_legend_handles_labels()
    _side_legend(axes[0][-1], handles, labels)
    name = _save(fig, out, "accuracy_cost.png")
    return name, text


def fig_cutoff(rows, out, colors) -> tuple[str | None, list[str]]:
    """Image error against the unbounded reference vs frame cost, over the light cutoff."""
    plt = _plt()
    cut = _sel(rows, study="cutoff")
    if not cut:
        return None, []
    scenes = _order(cut, "scene")
    fig, axes = plt.subplots(1, len(scenes), squeeze=False, dpi=DPI,
                             figsize=(5.6 * len(scenes) + 1.4, 3.6))
    text = []
    for ax, sc in zip(axes[0], scenes):
        sub = _sel(cut, scene=sc)
        ref = [r for r in sub if r["cutoff"] < 0]
        bounded = [r for r in sub if r["cutoff"] > 0]
        cutoffs = sorted(set(int(r["cutoff"]) for r in bounded))
        for t in _order(bounded, "technique"):
            tr = sorted(_sel(bounded, technique=t), key=lambda r: r["cutoff"])
            ax.plot([_num(r["frame_cost_ms"]) for r in tr], [max(_num(r["image_error"]), 1e-7) for r in tr],
                    color=colors(t), label=t, **colors.style(t))
            if t == REFERENCE:
                for r in tr:
                    ax.annotate(f"1/{int(r['cutoff'])}", (_num(r["frame_cost_ms"]), _num(r["image_error"])),
                                fontsize=7, xytext=(3, 3), textcoords="offset points")
        if ref:
            ax.axvline(_num(ref[0]["frame_cost_ms"]), color="0.3", ls=":", lw=1,
                       label=f"unbounded {REFERENCE}")
        _log_axes(ax)
        ax.set_xlabel("frame cost (ms)", fontsize=8)
        ax.set_ylabel("RMSE vs unbounded / mean radiance", fontsize=8)
        n = int(sub[0]["lights"])
        ax.set_title(f"light cutoff, {sc}, {n} lights", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3, which="both")
        errs = {c: _mean([r["image_error"] for r in bounded if int(r["cutoff"]) == c]) for c in cutoffs}
        vis = {c: _mean([r["visible"] for r in bounded if int(r["cutoff"]) == c
                         and r["technique"] == REFERENCE]) for c in cutoffs}
        ratio = {c: _mean([r["radiance_ratio"] for r in bounded if int(r["cutoff"]) == c]) for c in cutoffs}
        s = f"**{sc}**: image error against the unbounded reference is " + ", ".join(
            f"{errs[c]:.2g} at t=1/{c}" for c in cutoffs)
        s += " (the bounded image holds " + ", ".join(f"{100 * ratio[c]:.0f}%" for c in cutoffs) + \
             " of the reference's mean radiance"
        c0 = cutoffs[-1]
        if errs[c0] > 0 and 1.0 - ratio[c0] >= 0.5 * errs[c0]:
            s += "; most of the error is energy missing from the cut tails"
        s += ")"
        cheapest = {}
        for c in cutoffs:
            cands = [r for r in bounded if int(r["cutoff"]) == c and r["technique"] not in (REFERENCE, PERFECT)]
            if cands:
                b = min(cands, key=lambda r: _num(r["frame_cost_ms"]))
                cheapest[c] = (b["technique"], _num(b["frame_cost_ms"]))
        if cheapest:
            s += "; the cheapest technique costs " + ", ".join(
                f"{_ms(v[1])} ({v[0]}) at 1/{c}" for c, v in cheapest.items())
        if len(cutoffs) > 1 and cutoffs[0] in cheapest and cutoffs[-1] in cheapest:
            s += f": {_x(cheapest[cutoffs[-1]][1] / cheapest[cutoffs[0]][1])} the cost for " \
                 f"{_x(errs[cutoffs[0]] / max(errs[cutoffs[-1]], 1e-12))} less error"
        if ref:
            s += f". Visible lights grow from {vis[cutoffs[0]]:.0f} to {vis[cutoffs[-1]]:.0f}; the " \
                 f"unbounded reference ({int(ref[0]['visible'])} lights, no window) costs " \
                 f"{_ms(ref[0]['frame_cost_ms'])}"
        text.append(s + ".")
    _side_legend(axes[0][-1])
    name = _save(fig, out, "cutoff.png")
    return name, text


def fig_options(rows, out, colors) -> tuple[str | None, list[str]]:
    """Hybrid heuristic radius scale, and duplicated vs indexed lists (tree paper figure 5)."""
    plt = _plt()
    rad, lay = _sel(rows, study="radius"), _sel(rows, study="layout")
    if not rad and not lay:
        return None, []
    fig, axes = plt.subplots(1, 3, dpi=DPI, figsize=(13, 3.3))
    text = []
    for t in _order(rad, "technique"):
        tr = sorted(_sel(rad, technique=t), key=lambda r: r["radius_scale"])
        x = [_num(r["radius_scale"]) for r in tr]
        g = [_lighting(r) for r in tr]
        wst = [_num(r["waste"]) for r in tr]
        axes[0].plot(x, g, color=colors(t), label=t, **colors.style(t))
        axes[1].plot(x, wst, color=colors(t), label=t, **colors.style(t))
        i = int(np.argmin(g))
        text.append(f"{t}: radius_scale {x[i]:g} gives the lowest GPU lighting time ({_ms(g[i])}; "
                    f"{_ms(max(g))} at worst); waste goes from {wst[0]:.3g} at {x[0]:g} to "
                    f"{wst[-1]:.3g} at {x[-1]:g}.")
    for ax, title in zip(axes[:2], ("GPU cull + shade (ms)", "lights evaluated / affecting")):
        ax.set_xscale("log", base=2)
        ax.set_xlabel("radius_scale (cell.radius = scale x half cell depth)", fontsize=7)
        ax.set_title(title, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    if rad:
        axes[1].legend(fontsize=7)
    ltechs = _order(lay, "technique")
    metrics = (("CPU stage", "cpu_total_ms"), ("GPU shade", "gpu_shade_ms"), ("culling bytes", "bytes_culling"))
    width = 0.8 / max(len(ltechs), 1)
    for i, t in enumerate(ltechs):
        ind = _sel(lay, technique=t, duplicated=0.0)
        dup = _sel(lay, technique=t, duplicated=1.0)
        if not ind or not dup:
            continue
        ratios = [_num(dup[0][c]) / max(_num(ind[0][c]), 1e-9) for _, c in metrics]
        axes[2].bar(np.arange(len(metrics)) + i * width, ratios, width, color=colors(t), label=t)
        text.append(f"{t}: duplicated light data costs {_x(ratios[0])} the CPU time of indexed lists "
                    f"({_ms(dup[0]['cpu_total_ms'])} vs {_ms(ind[0]['cpu_total_ms'])}), "
                    f"{_x(ratios[1])} the shading time and {_x(ratios[2])} the bytes "
                    f"({_num(dup[0]['bytes_culling']) / 2**20:.2f} vs "
                    f"{_num(ind[0]['bytes_culling']) / 2**20:.2f} MiB).")
    axes[2].axhline(1.0, color="0.3", lw=1)
    axes[2].set_xticks(np.arange(len(metrics)) + 0.4 - width / 2, [m for m, _ in metrics], fontsize=8)
    axes[2].set_title("duplicated / indexed", fontsize=9)
    axes[2].tick_params(labelsize=7)
    if ltechs:
        axes[2].legend(fontsize=7)
    name = _save(fig, out, "options.png")
    return name, text


# ---------------------------------------------------------------------------- tables

def floor_table(rows) -> tuple[str, list[str]]:
    """Each technique's shading time as a position between brute (0%) and the floor (100%)."""
    agg = aggregate_path(rows)
    path = _sel(rows, study="path")
    techs = [t for t in _order(path, "technique")]
    lines = ["| scene, lights | " + " | ".join(techs) + " |", "|---" * (len(techs) + 1) + "|"]
    text = []
    for key, d in agg.items():
        b, f = d.get(REFERENCE), d.get(PERFECT)
        cells = []
        for t in techs:
            if t not in d:
                cells.append("-")
                continue
            pos = ""
            if b and f and b["shade"] > f["shade"]:
                pos = f" ({100 * (b['shade'] - d[t]['shade']) / (b['shade'] - f['shade']):.1f}%)"
            cells.append(f"{_ms(d[t]['shade'])}{pos}")
        lines.append(f"| {key[0]}, {key[1]} | " + " | ".join(cells) + " |")
        if b and f and b["shade"] > f["shade"]:
            others = {t: v["shade"] for t, v in d.items() if t not in (REFERENCE, PERFECT)}
            if others:
                best = min(others, key=others.get)
                text.append(f"{key[0]}, {key[1]} lights: {best} shades in {_x(others[best] / f['shade'])} "
                            f"the floor's time ({100 * (b['shade'] - others[best]) / (b['shade'] - f['shade']):.1f}% "
                            f"of the way from {REFERENCE} to perfect).")
    return "\n".join(lines), text


def summary_table(rows) -> str:
    agg = aggregate_path(rows)
    lines = ["| scene, lights | technique | evaluated/px | exact/px | waste | nodes/px | "
             "scalar iters/wave | culling KiB | CPU ms | GPU ms | mismatches | image error |",
             "|---" * 12 + "|"]
    for key, d in agg.items():
        for t, v in d.items():
            lines.append(f"| {key[0]}, {key[1]} | {t} | {v['evaluated']:.3g} | {v['exact']:.3g} | "
                         f"{v['waste']:.3g} | {v['nodes']:.3g} | {v['iters']:.3g} | "
                         f"{v['bytes'] / 1024:.0f} | {v['cpu']:.3g} | {v['gpu']:.3g} | {v['mism']:.0f} | "
                         f"{v['err']:.2g} |")
    return "\n".join(lines)


# ---------------------------------------------------------------------------- report.md

def write_report(out: Path, rows: list[dict], maps: dict, info: dict) -> list[str]:
    """Write every plot and report.md into `out`; returns the PNG names."""
    out = Path(out)
    techs = _order(rows, "technique")
    colors = Colors(techs)
    pngs = []
    sections = []

    def section(title, png, text, extra=""):
        if png is None and not text and not extra:
            return
        body = [f"## {title}", ""]
        for p in ([png] if isinstance(png, str) else (png or [])):
            body += [f"![{title}]({p})", ""]
            pngs.append(p)
        body += [t if t.startswith(("|", "-")) else f"- {t}" for t in text]
        if extra:
            body += ["", extra]
        sections.append("\n".join(body) + "\n")

    name, text = fig_accuracy(rows, out, colors)
    section("What accuracy costs: culling waste vs frame cost", name, text)
    name, text = fig_path(rows, out, colors)
    section("GPU lighting time along the camera path (tree paper figure 7)", name, text)
    ftable, ftext = floor_table(rows)
    section("Shading time against the perfect culler's floor", None, ftext,
            "Shading ms, mean over the path; in brackets the position between "
            f"{REFERENCE} (0%) and the perfect culler (100%).\n\n" + ftable)
    name, text, table = fig_cpu(rows, out, colors)
    section("CPU stage vs light count (tree paper figure 4, 4.1)", name, text,
            "Share of each step, mean over the light counts (min-max in brackets):\n\n" + table
            if table else "")
    name, text = fig_tile(rows, out, colors)
    section("Tile size (tree paper figure 6)", name, text)
    name, text = fig_heat(rows, maps, out, info)
    section("Lights evaluated per pixel (tree paper figure 1)", name, text)
    name, text = fig_classification(rows, maps, out)
    section("Traversal per wave: list / tree / mixed (tree paper figure 3)", name, text)
    name, text = fig_cutoff(rows, out, colors)
    section("The light cutoff: image error vs cost", name, text,
            "Each light's radius is set where its unbounded falloff I/(d^2+1) drops to t times the "
            "brightest light's peak: radius_i = sqrt(I_i / (t I_max) - 1), I_i = intensity x "
            "brightest colour channel; lights never that bright are dropped.  radius ~ sqrt(I), "
            "and the builtin scenes draw I ~ r^2, so the many-small-few-large law is kept.  The "
            "reference renders every light with UNBOUNDED_FALLOFF=1 (attenuation 1/(d^2+1), no "
            "window).")
    name, text = fig_options(rows, out, colors)
    section("Options: hybrid radius scale, duplicated vs indexed (tree paper figure 5)", name, text)
    sections.append("## Hardware-neutral figures (camera path, mean over frames)\n\n"
                    + summary_table(rows) + "\n")

    sw = info.get("software", False)
    head = [
        "# Many-light culling benchmark", "",
        f"- command: `{info.get('command', '')}` (preset `{info.get('preset', '')}`)",
        f"- machine: {info.get('cpu', '?')}, {info.get('cores', '?')} cores; "
        f"{info.get('system', '')}, Python {info.get('python', '')}",
        f"- GL: {info.get('gl_renderer', '?')} ({info.get('gl_version', '')})",
        f"- CPU stage: {info.get('cpu_threads', '?')} numba thread(s) (the paper's figure 4 is "
        f"single threaded)",
        f"- run time: {info.get('elapsed_s', 0):.0f} s; {len(rows)} rows in results.csv",
        "",
    ]
    if sw:
        head += ["> **Software rasterizer.** GPU passes were timed as wall clock around the "
                 "dispatch plus glFinish on a CPU rasterizer that shares the cores with the CPU "
                 "stage. GPU times here are only comparable as ratios between techniques within "
                 "this run, never as absolute GPU figures.", ""]
    else:
        head += ["GPU passes timed with GL timer queries.", ""]
    path = _sel(rows, study="path")
    mism = sum(_num(r["mismatch_count"]) + _num(r["mismatch_hash"]) for r in rows
               if r["study"] != "cpu" and not math.isnan(_num(r["mismatch_count"])))
    head += [f"Exactness: {int(mism)} pixels differ from {REFERENCE} in contrib_count or "
             f"contrib_hash over every rendered configuration (must be 0).  Columns, studies and "
             f"the timing method are described in `app/bench.py`; the same command gives the same "
             f"table apart from the timing columns (*_ms, gpu_passes, floor_position_pct).", ""]
    if path:
        r0 = path[0]
        head += [f"Camera-path study at {int(r0['width'])}x{int(r0['height'])}, "
                 f"{int(r0['frames'])} frames along the path, tile {int(r0['tile'])}, "
                 f"{int(r0['slices'])} slices; frame cost = CPU stage (cull, sort, bin, build, pack, "
                 f"upload) + GPU culling prepasses + shading; the perfect culler's cost is its "
                 f"shared CPU steps + shading (its lists are built untimed).", ""]
    (out / "report.md").write_text("\n".join(head) + "\n" + "\n".join(sections))
    return pngs


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        raise SystemExit("usage: python -m app.report DIR")
    out = Path(argv[0])
    rows = read_csv(out / "results.csv")
    maps = dict(np.load(out / "maps.npz")) if (out / "maps.npz").exists() else {}
    info = json.loads((out / "run.json").read_text()) if (out / "run.json").exists() else {}
    write_report(out, rows, maps, info)


if __name__ == "__main__":
    main()
