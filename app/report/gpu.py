"""The modelled GPU cost (app.model.cost) of every technique at 1920x1080: per scene and
named GPU, the modelled lighting time (culling passes + shading), the fastest technique, the
Pareto front of culling waste against it, beside what llvmpipe's measurement ranks first.

Reads the paper_scenes rows (app.bench.validation) and the path rows; the GPUs come from
the rows' model_<key>_* columns (the model's GPUS), never named here."""
from __future__ import annotations

import math

import numpy as np

from ..model import cost
from ..results import PAPER_PREFIX
from .aggregate import aggregate_path, pareto
from . import gpu_record
from .common import DPI, gmean, log_axes, num, order, panel_style, plt, save, sel, side_legend

SCENES = PAPER_PREFIX + "scenes"


def gpus_in(rows) -> list:
    return [g for g in cost.GPUS if any(f"model_{g.key}_lighting_ms" in r for r in rows[:1])]


lighting = gpu_record.lighting


def fig_gpu_scenes(rows, out, colors, roles) -> tuple[str | None, list[str]]:
    """Bars: modelled lighting ms per scene and technique, one panel per GPU."""
    sub = sel(rows, study=SCENES)
    gpus = gpus_in(sub)
    if not sub or not gpus:
        return None, []
    scenes, techs = order(sub, "scene"), order(sub, "technique")
    fig, axes = plt().subplots(2, 2, squeeze=False, dpi=DPI, figsize=(12, 7.2))
    width = 0.8 / len(techs)
    for ax, g in zip(axes.ravel(), gpus):
        for k, t in enumerate(techs):
            vals = [next((lighting(r, g) for r in sel(sub, scene=s, technique=t)), math.nan)
                    for s in scenes]
            ax.bar(np.arange(len(scenes)) + (k - len(techs) / 2 + 0.5) * width, vals, width,
                   color=colors(t), label=t)
        ax.set_xticks(np.arange(len(scenes)), scenes, fontsize=8)
        ax.set_yscale("log")
        panel_style(ax, g.name, "", "modelled GPU lighting ms (culling passes + shading)")
    for ax in axes.ravel()[len(gpus):]:
        ax.axis("off")
    side_legend(axes[0][-1], *axes[0][0].get_legend_handles_labels())
    r0 = sub[0]
    text = [f"Every technique at {int(r0['width'])}x{int(r0['height'])}, {int(r0['lights'])} "
            f"lights, frame 0 of each scene's path, modelled (model v{r0.get('model_version', '?')}; "
            f"the reference renders too, the floor is left out: its set-up is minutes a frame on "
            f"llvmpipe).  The fastest per GPU, and the next within 10%:"]
    path = aggregate_path(rows)
    for s in scenes:
        cells = []
        for g in gpus:
            v = {t: lighting(r, g) for r in sel(sub, scene=s) for t in [r["technique"]]}
            v = {t: x for t, x in v.items() if not math.isnan(x)}
            best = min(v, key=v.get)
            near = [t for t in v if t != best and v[t] <= 1.1 * v[best]]
            bound = next(r.get(f"model_{g.key}_bound") for r in sel(sub, scene=s, technique=best))
            cells.append(f"{g.key} **{best}** {v[best]:.3g} ms ({bound}-bound)" +
                         (f" ({', '.join(near)} within 10%)" if near else ""))
        measured = _llvmpipe_fastest(path, s, roles)
        text.append(f"**{s}**: " + "; ".join(cells) +
                    (f".  Measured on llvmpipe (path study, {measured})." if measured else "."))
    return save(fig, out, "gpu_scenes.png"), text


def _llvmpipe_fastest(path: dict, scene: str, roles) -> str:
    keys = [k for k in path if k[0] == scene]
    if not keys:
        return ""
    key = max(keys, key=lambda k: k[1])
    d = {t: v["gpu"].med for t, v in path[key].items() if t != roles.floor}
    best = min(d, key=d.get)
    return f"{key[1]} lights: {best} fastest, {d[best]:.3g} ms"


def fig_gpu_pareto(rows, out, colors, roles) -> tuple[str | None, list[str]]:
    """Per GPU: culling waste against modelled lighting time, geometric means over the
    scenes, with the Pareto front; the text gives each scene's front."""
    sub = [r for r in sel(rows, study=SCENES) if r["role"] != "floor"]
    gpus = gpus_in(sub)
    if not sub or not gpus:
        return None, []
    techs, scenes = order(sub, "technique"), order(sub, "scene")
    fig, axes = plt().subplots(2, 2, squeeze=False, dpi=DPI, figsize=(11, 7.4))
    text = []
    for ax, g in zip(axes.ravel(), gpus):
        pts = {}
        for t in techs:
            tr = sel(sub, technique=t)
            waste = gmean(r["waste"] for r in tr)
            pts[t] = (gmean(lighting(r, g) for r in tr), waste)
            ax.scatter([pts[t][0]], [waste], color=colors(t), zorder=3, label=t)
            ax.annotate(t, pts[t], fontsize=7, xytext=(4, 3), textcoords="offset points")
        front = pareto(pts)
        ax.step([pts[t][0] for t in front], [pts[t][1] for t in front], where="post",
                color="0.4", lw=1, ls=":", label="Pareto front")
        log_axes(ax)
        panel_style(ax, g.name, "modelled GPU lighting ms (geometric mean over the scenes)",
                    "lights evaluated / lights affecting")
        fronts = []
        for s in scenes:
            p = {r["technique"]: (lighting(r, g), num(r["waste"])) for r in sel(sub, scene=s)}
            fronts.append(f"{s} " + " -> ".join(pareto(p)))
        text.append(f"**{g.key}** (geometric mean: " + " -> ".join(front) + "); per scene: "
                    + "; ".join(fronts) + ".")
    for ax in axes.ravel()[len(gpus):]:
        ax.axis("off")
    side_legend(axes[0][-1], *axes[0][0].get_legend_handles_labels())
    return save(fig, out, "gpu_pareto.png"), text


def believe_text(rows, info, roles) -> list[str]:
    """The report's opening: which figure answers which question."""
    gpus = gpus_in(rows)
    names = ", ".join(g.name for g in gpus)
    software = info.get("software", True)
    rec = gpu_record.record()
    out = ["**Which number to believe for which question.**", "",
           "- *Which structure culls best, and how much data it needs*: the hardware-neutral "
           "figures (lights evaluated per affecting light, nodes, bytes). They are exact, the "
           "same on any machine, and checked pixel by pixel against the reference.",
           f"- *What a technique costs on a GPU*: the **modelled** GPU milliseconds (model "
           f"v{cost.MODEL_VERSION}: {names}; app/model/cost.py, from public specifications, "
           f"never fitted). Read them as a ranking on one GPU, and only where two techniques "
           f"are far apart; the absolute scale is an estimate: it ignores occupancy and "
           f"latency (reading low), and charges every pixel's G-buffer and colour at full DRAM "
           f"bandwidth (a floor that reads high: EpicCitadel's 0.38 ms in the tree paper is "
           f"below it). " + (f"Held to a real GPU: {rec.sentence()}. " if rec else
                            "No real GPU has measured it yet. ") +
           f"The validation section says, by one rule, where they agree with the "
           f"papers' measurements, and which rows sit on a floor.",
           "- *What it costs on this machine's software rasterizer*: the llvmpipe "
           "milliseconds (gpu_*_ms). They are measured, but on a CPU that pays every wave "
           "vote with barriers: they rank the papers' wave techniques (hybrid's paths, zbin's "
           "scalarized loop) lower than a GPU would. Use them for llvmpipe only.",
           "- *What the CPU stage costs*: measured on this machine's CPU (cpu_*_ms), real."]
    if not software:
        out.append("- This run had a real GPU: its gpu_*_ms are measured on it (GL timer "
                   "queries); set them beside the modelled ones in the validation section.")
    return out + [""]


def fig_measured(rows, out, colors, info) -> tuple[str | None, list[str], str]:
    """A real GPU's measured lighting ms against the model of that GPU (or, for a GPU the
    model does not name, its closest kind), per technique; on a software rasterizer: says so,
    and cites the committed real-GPU record where there is one."""
    if info.get("software", True):
        rec = gpu_record.record()
        held = (f"In {rec.sentence()}." if rec else "No real GPU has measured the model yet.")
        return None, ["No real GPU in this run (GL: " + str(info.get("gl_renderer", "?")) +
                      "). " + held + "  On a machine with a GPU, `bash scripts/gpu_check.sh` "
                      "measures every technique there and writes this section with its "
                      "figures."], ""
    g, named = gpu_record.model_of(str(info.get("gl_renderer", "")))
    rendered = gpu_record.measured_rows(rows)
    if not rendered:
        return None, [], ""
    fig, ax = plt().subplots(dpi=DPI, figsize=(6.5, 5.2))
    lines = ["| technique | measured lighting ms (median over rows) | modelled | measured / modelled |",
             "|---|---|---|---|"]
    ratios = gpu_record.ratios(rendered, g)
    for t in order(rendered, "technique"):
        tr = sel(rendered, technique=t)
        m = np.array([num(r["gpu_lighting_ms"]) for r in tr])
        p = np.array([lighting(r, g) for r in tr])
        ax.scatter(p, m, color=colors(t), label=t, s=14)
        lines.append(f"| {t} | {np.median(m):.3g} | {np.median(p):.3g} | {ratios[t]:.2f}x |")
    lo = min(ax.get_xlim()[0], ax.get_ylim()[0])
    hi = max(ax.get_xlim()[1], ax.get_ylim()[1])
    ax.plot([lo, hi], [lo, hi], color="0.5", ls=":", lw=1, label="measured = modelled")
    log_axes(ax)
    panel_style(ax, f"{info.get('gl_renderer')} against the model of {g.name}",
                "modelled lighting ms", "measured lighting ms (GL timer queries)")
    side_legend(ax, *ax.get_legend_handles_labels())
    same, frames, alike, pairs = gpu_record.rank_agreement(rendered, g)
    low, high = min(ratios.values()), max(ratios.values())
    tie = f"{gpu_record.TIE:.0%}"
    text = [f"Measured on **{info.get('gl_renderer')}** (GL timer queries, every timed pass) "
            f"against model v{cost.MODEL_VERSION} of {g.name}" +
            ("" if named else " (the model does not name this GPU: the nearest it has)") + ".",
            f"In {same} of {frames} frames the modelled order of the techniques equals the "
            f"measured one, up to ties within {tie}; of the technique pairs a frame's "
            f"measurement sets more than {tie} apart, the model orders {alike} of {pairs} "
            f"alike (or within {tie}); the model's ratio of two techniques' times misses the "
            f"measured one by a median factor of {gpu_record.pair_error(rendered, g):.2g}.",
            f"Measured / modelled, per technique: {low:.3g}x to {high:.3g}x (geometric mean "
            f"{gmean(np.array(list(ratios.values()))):.3g}x): the model's absolute times are " +
            ("within 2x of this GPU's." if 0.5 <= low and high <= 2 else
             "not this GPU's; read its ms as a ranking at most, as far as the pairs above "
             "bear it out.")]
    return save(fig, out, "measured_vs_modelled.png"), text, "\n".join(lines)
