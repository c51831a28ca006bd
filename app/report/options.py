"""The option studies (tree paper figures 5 and 6, generalised): one figure per studied
option, whatever the option.  A numeric option plots GPU lighting time, frame cost and
culling waste against its values per technique (and, where it was measured at another
resolution, the CPU stage alone in its own panel, never added to the GPU times); a boolean
option plots the ratio on / off of each figure as bars.  Error bars are the samples' min-max.
"""
from __future__ import annotations

import math

import numpy as np

from ..results import CPU_PREFIX, FIXED_STUDIES, option_specs
from .common import DPI, log_axes, ms, num, order, panel_style, plt, resolution, save, sel, side_legend, times
from .spread import Spread, lowest_phrase, ratio_phrase


def studied_options(rows) -> list[tuple[str, bool]]:
    """(option name, is boolean) of each option study in the rows, in order."""
    if not rows:
        return []
    specs = option_specs()
    out = []
    for s in order(rows, "study"):
        if s in FIXED_STUDIES or s not in rows[0]:
            continue
        if s in specs:
            is_bool = specs[s].kind is bool
        else:       # a results.csv of an option no longer registered: judge by its values
            is_bool = {num(r[s]) for r in sel(rows, study=s)} <= {0.0, 1.0}
        out.append((s, is_bool))
    return out


def fig_option(rows, name: str, is_bool: bool, out, colors) -> tuple[str | None, list[str]]:
    study = sel(rows, study=name)
    if not study:
        return None, []
    cpu = sel(rows, study=CPU_PREFIX + name)
    return (_bool_figure if is_bool else _numeric_figure)(study, cpu, name, out, colors)


def _errorbar(ax, x, spreads, color, label, style):
    ax.errorbar(x, [s.med for s in spreads],
                yerr=[[s.med - s.lo for s in spreads], [s.hi - s.med for s in spreads]],
                color=color, label=label, capsize=2, elinewidth=1, **style)


def _numeric_figure(study, cpu, name, out, colors):
    res = resolution(study[0])
    panels = [(f"GPU cull + shade at {res} (ms)", "gpu_lighting"),
              (f"frame cost at {res}: CPU + GPU cull + shade (ms)", "frame_cost"),
              ("lights evaluated / affecting", "waste")]
    if cpu:
        panels.append((f"CPU stage alone at {resolution(cpu[0])} (ms; not added)", "cpu_total"))
    fig, axes = plt().subplots(1, len(panels), dpi=DPI, squeeze=False,
                               figsize=(3.6 * len(panels) + 1.6, 3.3))
    axes = axes[0]
    values = sorted(set(num(r[name]) for r in study))
    label = lambda v: f"{name} {v:g}"
    text = []
    for t in order(study, "technique"):
        tr = sorted(sel(study, technique=t), key=lambda r: num(r[name]))
        x = [num(r[name]) for r in tr]
        for ax, (_, col) in zip(axes, panels):
            if col == "waste":
                ax.plot(x, [num(r["waste"]) for r in tr], color=colors(t), label=t, **colors.style(t))
                continue
            src = sorted(sel(cpu, technique=t), key=lambda r: num(r[name])) \
                if col == "cpu_total" else tr
            if src:
                _errorbar(ax, [num(r[name]) for r in src], [Spread.of(r, col) for r in src],
                          colors(t), t, colors.style(t))
        g = {v: Spread.of(r, "gpu_lighting") for v, r in zip(x, tr)}
        c = {v: Spread.of(r, "frame_cost") for v, r in zip(x, tr)}
        w = [num(r["waste"]) for r in tr]
        s = (f"{t}: " + lowest_phrase(g, "GPU lighting", label) + "; " +
             lowest_phrase(c, "frame cost", label) +
             f"; waste goes from {w[0]:.3g} at {x[0]:g} to {w[-1]:.3g} at {x[-1]:g}")
        ct = sorted(sel(cpu, technique=t), key=lambda r: num(r[name]))
        if ct:
            s += (f"; the CPU stage alone at {resolution(ct[0])} goes from "
                  f"{ms(ct[0]['cpu_total_ms'])} at {num(ct[0][name]):g} to "
                  f"{ms(ct[-1]['cpu_total_ms'])} at {num(ct[-1][name]):g}")
        text.append(s + ".")
    spec = option_specs().get(name)
    log2 = (spec is None or spec.kind is float) and values[0] > 0 and values[-1] / values[0] >= 4
    for ax, (title, _) in zip(axes, panels):
        if log2:
            ax.set_xscale("log", base=2)
        ax.set_xticks(values, [f"{v:g}" for v in values])
        ax.minorticks_off()
        panel_style(ax, title, name)
    side_legend(axes[-1])
    r0 = study[0]
    fig.suptitle(f"{name}, {r0['scene']}, {int(r0['lights'])} lights, frame {int(r0['frame'])}",
                 fontsize=9)
    return save(fig, out, f"option_{name}.png"), text


def _bool_figure(study, cpu, name, out, colors):
    res = resolution(study[0])
    metrics = [(f"CPU stage\nat {res}", "cpu_total", True), ("GPU cull\n+ shade", "gpu_lighting", True),
               ("frame\ncost", "frame_cost", True), ("culling\nbytes", "bytes_culling", False),
               ("waste", "waste", False)]
    if cpu:
        metrics.append((f"CPU stage\nat {resolution(cpu[0])}", "cpu_only", True))
    techs = order(study, "technique")
    fig, axes = plt().subplots(1, 1, dpi=DPI, squeeze=False, figsize=(1.3 * len(metrics) + 3.0, 3.3))
    ax = axes[0][0]
    width = 0.8 / max(len(techs), 1)
    text = []
    for i, t in enumerate(techs):
        on, off = sel(study, technique=t, **{name: 1.0}), sel(study, technique=t, **{name: 0.0})
        if not on or not off:
            continue
        on, off = on[0], off[0]
        cpu_on = sel(cpu, technique=t, **{name: 1.0})
        cpu_off = sel(cpu, technique=t, **{name: 0.0})
        ratios = []
        for _, col, timed in metrics:
            if col == "cpu_only":
                r = Spread.of(cpu_on[0], "cpu_total").ratio(Spread.of(cpu_off[0], "cpu_total")) \
                    if cpu_on and cpu_off else Spread(math.nan, math.nan, math.nan, 1)
            elif timed:
                r = Spread.of(on, col).ratio(Spread.of(off, col))
            else:
                v = num(on[col]) / max(num(off[col]), 1e-12)
                r = Spread(v, v, v, 0)
            ratios.append(r)
        xs = np.arange(len(metrics)) + i * width
        ax.bar(xs, [r.med for r in ratios], width, color=colors(t), label=t,
               yerr=[[max(r.med - r.lo, 0) for r in ratios], [max(r.hi - r.med, 0) for r in ratios]],
               capsize=2, error_kw=dict(elinewidth=1))
        by = dict(zip((m[1] for m in metrics), ratios))
        s = (f"{t}: {name} on / off: CPU stage {ratio_phrase(by['cpu_total'])}, GPU lighting "
             f"{ratio_phrase(by['gpu_lighting'])}, frame cost {ratio_phrase(by['frame_cost'])}, "
             f"culling bytes {times(by['bytes_culling'].med)} ({num(on['bytes_culling']) / 2**20:.2f} "
             f"vs {num(off['bytes_culling']) / 2**20:.2f} MiB), waste {times(by['waste'].med)}")
        if "cpu_only" in by and not math.isnan(by["cpu_only"].med):
            s += f"; the CPU stage alone at {resolution(cpu[0])}: {ratio_phrase(by['cpu_only'])}"
        text.append(s + ".")
    ax.axhline(1.0, color="0.3", lw=1)
    log_axes(ax, x=False)            # ratios: 2x and 1/2x equally far from 1
    ax.set_xticks(np.arange(len(metrics)) + 0.4 - width / 2, [m[0] for m in metrics], fontsize=7)
    panel_style(ax, f"{name}: on / off", "", "ratio (min-max of samples)")
    side_legend(ax)
    r0 = study[0]
    fig.suptitle(f"{name}, {r0['scene']}, {int(r0['lights'])} lights, frame {int(r0['frame'])}",
                 fontsize=9)
    return save(fig, out, f"option_{name}.png"), text
