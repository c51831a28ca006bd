"""Tree paper figure 4 and section 4.1: the CPU stage alone vs light count, stacked by step,
and each step's share against the paper's."""
from __future__ import annotations

import math

import numpy as np

from ..results import STAGES
from .common import DPI, ms, num, order, plt, resolution, save, sel, side_legend, times

# The tree paper's CPU step shares (4.1, tree creation on an i7-4790K); pack is not named there.
PAPER_SHARES = {"bin": 50.0, "build": 25.0, "sort": 12.0, "upload": 7.0, "cull": 3.0}
STAGE_COLORS = dict(zip(STAGES, ("#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860")))


def stage_shares(cpu_rows) -> dict:
    """{technique: {stage: (mean share %, min, max over light counts)}} of the CPU series."""
    out = {}
    for t in order(cpu_rows, "technique"):
        shares = {k: [] for k in STAGES}
        for r in sel(cpu_rows, technique=t):
            tot = sum(num(r[f"cpu_{k}_ms"]) for k in STAGES)
            if tot > 0:
                for k in STAGES:
                    shares[k].append(100.0 * num(r[f"cpu_{k}_ms"]) / tot)
        out[t] = {k: (float(np.mean(v)), float(np.min(v)), float(np.max(v))) if v else (0, 0, 0)
                  for k, v in shares.items()}
    return out


def fig_cpu(rows, out) -> tuple[str | None, list[str], str]:
    """Figure 4 (the "cpu" study) and, after its tables, the growth series (growth_report),
    the CPU and GPU builds' ratio (gpu_build_report: rows of study "gpu_build", or
    out/gpu_build.csv from `python -m app.bench gpu-build --out`) and the CPU stage against
    the plain C reference (c_reference_report: rows of study "c_reference")."""
    name, text, table = _fig4(rows, out)
    png, gtext, gtables = growth_report(rows, out)
    btext, btable = gpu_build_report(gpu_build_rows(rows, out))
    ctext, ctable = c_reference_report(sel(rows, study=C_REFERENCE_STUDY)
                                       if rows and "study" in rows[0] else [])
    parts = []
    if png or gtext:
        parts.append("\n\n".join(x for x in (
            "### Growth from 8k to 1M lights", f"![CPU stage growth]({png})" if png else "",
            _bullets(gtext), gtables) if x))
    if btext:
        parts.append("\n\n".join(("### The build on the CPU and on the GPU (--build gpu)",
                                   _bullets(btext), btable)))
    if ctext:
        parts.append("\n\n".join(("### Against plain single-threaded C",
                                   _bullets(ctext), ctable)))
    if not parts:
        return name, text, table
    if name is None:           # no figure 4 rows: the series alone, their images inline
        return None, [], "\n\n".join(parts)
    return name, text, "\n\n".join([table] + parts)


def _bullets(text) -> str:
    return "\n".join(t if t.startswith(("|", "-")) else f"- {t}" for t in text)


def _fig4(rows, out) -> tuple[str | None, list[str], str]:
    cpu = sel(rows, study="cpu")
    if not cpu:
        return None, [], ""
    techs = order(cpu, "technique")
    counts = sorted(set(int(r["lights"]) for r in cpu))
    one = lambda t, n: sel(cpu, technique=t, lights=float(n))[0]
    fig, axes = plt().subplots(1, len(techs), squeeze=False, dpi=DPI, sharey=True,
                               figsize=(2.5 * len(techs) + 1.4, 3.3))
    for j, t in enumerate(techs):
        ax = axes[0][j]
        bottom = np.zeros(len(counts))
        for k in STAGES:
            v = np.array([num(one(t, n)[f"cpu_{k}_ms"]) for n in counts])
            ax.bar(range(len(counts)), v, bottom=bottom, color=STAGE_COLORS[k], label=k)
            bottom += v
        ax.set_xticks(range(len(counts)), [f"{n // 1024}k" if n >= 1024 else str(n) for n in counts],
                      fontsize=7)
        ax.set_title(t, fontsize=9)
        ax.set_xlabel("lights", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3, axis="y")
    axes[0][0].set_ylabel("CPU ms (median)", fontsize=8)
    side_legend(axes[0][-1])
    fig.suptitle(f"CPU stage, {cpu[0]['scene']} at {resolution(cpu[0])}", fontsize=9)
    name = save(fig, out, "cpu_stages.png")

    text, lo, hi = [], counts[0], counts[-1]
    totals = {t: {n: sum(num(one(t, n)[f"cpu_{k}_ms"]) for k in STAGES) for n in counts}
              for t in techs}
    if hi > lo:
        growth = ", ".join(f"{t} {ms(totals[t][lo])} -> {ms(totals[t][hi])} "
                           f"({times(totals[t][hi] / max(totals[t][lo], 1e-9))})" for t in techs)
        text.append(f"From {lo} to {hi} lights ({times(hi / lo)} the lights) the CPU stage "
                    f"(median) grows: {growth}.")
    small = [n for n in counts if n <= 8192]
    if small:
        # "stays under" holds for every sample: the slowest one (max) is compared
        under = [t for t in techs if all(num(one(t, n)["cpu_total_max_ms"]) < 2.0 for n in small)]
        who = ("every technique stays" if len(under) == len(techs) else
               f"{', '.join(under)} {'stays' if len(under) == 1 else 'stay'}" if under else
               "no technique stays")
        text.append(f"At 8192 lights or fewer {who} under 2 ms in every sample (the paper: "
                    f"every technique under 2 ms there, single threaded on an i7-4790K).")
    shares = stage_shares(cpu)
    table = ["| technique | " + " | ".join(STAGES) + f" | total at {hi} lights |",
             "|---" * (len(STAGES) + 2) + "|"]
    for t in techs:
        cells = [f"{shares[t][k][0]:.0f}% ({shares[t][k][1]:.0f}-{shares[t][k][2]:.0f})" for k in STAGES]
        table.append(f"| {t} | " + " | ".join(cells) + f" | {ms(totals[t][hi])} |")
    table.append("| *paper, tree (i7-4790K)* | " + " | ".join(
        f"*{PAPER_SHARES[k]:.0f}%*" if k in PAPER_SHARES else "-" for k in STAGES) + " | - |")
    # the techniques whose CPU stage has the paper's steps (binning and a build step)
    for t in [t for t in techs if shares[t]["build"][0] > 0 and shares[t]["bin"][0] > 0]:
        top = max(STAGES, key=lambda k: shares[t][k][0])
        text.append(f"{t}: the largest step is {top} ({shares[t][top][0]:.0f}%); binning takes "
                    f"{shares[t]['bin'][0]:.0f}% (paper 50%), building {shares[t]['build'][0]:.0f}% "
                    f"(paper 25%), sorting {shares[t]['sort'][0]:.0f}% (12%), upload "
                    f"{shares[t]['upload'][0]:.0f}% (7%), culling {shares[t]['cull'][0]:.0f}% (3%).")
    return name, text, "\n".join(table)


# ---- growth: the CPU stage from 8k to 1M lights ------------------------

GROWTH_STUDY = "growth"          # app.bench.cpu.GROWTH
LINEAR = (0.85, 1.15)            # a doubling whose exponent log2(t(2n) / t(n)) lies here is linear
SCENE_RECORD = 84                # bytes of a scene light record the pack gathers (LIGHT_DTYPE)
# what each step does per light, and so why it may stop growing linearly (docs/cpu_stage.md)
STAGE_WHY = {
    "cull": "streams every light once (sphere and frustum, 12 B written a light): linear",
    "sort": "radix-sorts the visible lights' 8-byte (key | id) words in 3 passes of 11 bits, "
            "each scattering into 2,048 buckets: linear in the lights, dearer a word once the "
            "words outgrow the L2",
    "pack": f"gathers each visible light's {SCENE_RECORD}-byte scene record in depth order "
            "(random reads): a cache miss a light once the records outgrow the caches",
    "bin": "writes each light into every cell it overlaps through per-cell cursors (scattered "
           "stores, list entries in proportion to the lights)",
    "build": "walks each cell's entries (listing 2, the trees)",
}
# where a technique's step does other work than the shared reading above
TECHNIQUE_WHY = {
    ("zbin", "build"): "fills the tile bit arrays, tiles x lights/32 words: the 32 MiB budget "
                       "holds them by doubling the tile (a quarter of the tiles), so between "
                       "two doublings of the tile the words per tile double with the lights "
                       "and the tiles stay: the cost follows a sawtooth around linear",
    ("raster", "build"): "fits every visible light's proxy mesh in numpy: a dozen temporary "
                         "arrays of N x 3 (x 3) float64 a step, past the L3 from some 100k "
                         "lights, each pass over them a stream from memory",
    ("fptl", "bin"): "projects each light's screen rectangle and depth range (16 B a light) "
                     "and orders them for the GPU's coarse pass",
}


def _st(r) -> dict:
    import json
    v = r.get("stats")
    return json.loads(v) if isinstance(v, str) and v else {}


def _threads(r) -> int:
    return int(_st(r).get("threads", 1))


def _series(rows):
    """{(technique, threads): rows by ascending light count} of the growth study."""
    out: dict = {}
    for r in sorted(rows, key=lambda r: num(r["lights"])):
        out.setdefault((r["technique"], _threads(r)), []).append(r)
    return out


def _k(n) -> str:
    n = int(n)
    return f"{n >> 20}M" if n >= 1 << 20 and n % (1 << 20) == 0 else f"{n >> 10}k" if n >= 1024 else str(n)


def _mib(b) -> str:
    b = num(b)
    return f"{b / 2**20:.3g} MiB" if b >= 2**20 else f"{b / 1024:.3g} KiB"


def _exponents(values) -> list[float]:
    """log2 of each doubling's ratio (1.0: linear), over consecutive points."""
    return [math.log2(b / a) if a > 0 and b > 0 else math.nan for a, b in zip(values, values[1:])]


def _total_bytes(r) -> float:
    return num(r["bytes_lights"]) + num(r["bytes_culling"])


def growth_figure(series, out, techs) -> str | None:
    if out is None:
        return None
    from matplotlib.lines import Line2D
    colors = dict(zip(techs, plt().get_cmap("tab10").colors))
    fig, (a, b) = plt().subplots(1, 2, dpi=DPI, figsize=(10.5, 3.8))
    counts = sorted({num(r["lights"]) for rs in series.values() for r in rs})
    for (t, th), rs in series.items():
        n = np.array([num(r["lights"]) for r in rs])
        med = np.array([num(r["cpu_total_ms"]) for r in rs])
        lo = np.array([num(r["cpu_total_min_ms"]) for r in rs])
        hi = np.array([num(r["cpu_total_max_ms"]) for r in rs])
        a.errorbar(n, med, yerr=[med - lo, hi - med], color=colors[t], marker="o", ms=3,
                   ls="-" if th == 1 else "--", lw=1, capsize=2)
        if th == min(k[1] for k in series if k[0] == t):
            b.plot(n, [_total_bytes(r) / 2**20 for r in rs], color=colors[t], marker="o", ms=3, lw=1)
    for ax, what in ((a, "CPU stage ms (median, min-max)"), (b, "bytes of the build's buffers (MiB)")):
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xticks(counts, [_k(n) for n in counts])
        x0, x1 = ax.get_xlim()
        y0 = ax.get_ylim()[0]
        xs = np.array([x0, x1])
        ax.plot(xs, y0 * 2 * xs / x0, color="0.6", ls=":", lw=1)
        ax.set_xlabel("lights", fontsize=8)
        ax.set_ylabel(what, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3, which="both")
    handles = [Line2D([], [], color=colors[t], marker="o", ms=3, lw=1, label=t) for t in techs]
    handles += [Line2D([], [], color="k", lw=1, label="1 thread"),
                Line2D([], [], color="k", lw=1, ls="--", label="2 threads"),
                Line2D([], [], color="0.6", lw=1, ls=":", label="linear (slope 1)")]
    side_legend(b, handles, [h.get_label() for h in handles])
    r0 = next(iter(series.values()))[0]
    fig.suptitle(f"CPU stage growth, {r0['scene']} at {resolution(r0)} (log-log)", fontsize=9)
    return save(fig, out, "cpu_growth.png")


def _why(technique: str, stage: str) -> str:
    return TECHNIQUE_WHY.get((technique, stage), STAGE_WHY[stage])


def _why_superlinear(rs, j, caches) -> str:
    """The step that adds most beyond a doubling's 2x between rs[j] and rs[j + 1], and the
    working sets against the caches there."""
    a, b = rs[j], rs[j + 1]
    excess = {k: num(b[f"cpu_{k}_ms"]) - 2 * num(a[f"cpu_{k}_ms"]) for k in STAGES if k != "upload"}
    top = max(excess, key=lambda k: excess[k])       # medians: the step, not the total
    vis = num(b["visible"])
    sets = [f"{vis * SCENE_RECORD / 2**20:.3g} MiB of scene records, {vis * 8 / 2**20:.3g} MiB "
            f"of sort words, {_mib(_total_bytes(b))} of buffers"]
    beyond = [f"{k} ({_mib(v)})" for k, v in caches.items() if k != "L1d" and vis * 8 > v]
    where = f"; the sort words alone outgrow {', '.join(beyond)}" if beyond else ""
    return (f"{top} adds the most ({ms(num(a[f'cpu_{top}_ms']))} -> {ms(num(b[f'cpu_{top}_ms']))}): "
            f"it {_why(b['technique'], top)}; at {_k(b['lights'])} lights the frame holds "
            f"{sets[0]}{where}")


def _fixed_part(rs) -> tuple[float, float]:
    """(a ms, b ns a light) of t = a + b n fitted to the minimums of the two smallest counts."""
    n0, n1 = num(rs[0]["lights"]), num(rs[1]["lights"])
    t0, t1 = num(rs[0]["cpu_total_min_ms"]), num(rs[1]["cpu_total_min_ms"])
    b = (t1 - t0) / (n1 - n0)
    return t0 - b * n0, b * 1e6


def doubling_kinds(rs) -> list[str]:
    """Per doubling of rs (by ascending count): "super" when both the fastest builds' and
    the medians' ratio pass exponent LINEAR[1], "sub" when both stay under LINEAR[0], else
    "linear" (one outlying build of a shared machine moves one of them, not both)."""
    out = []
    for a, b in zip(rs, rs[1:]):
        e = [math.log2(max(num(b[k]), 1e-12) / max(num(a[k]), 1e-12))
             for k in ("cpu_total_min_ms", "cpu_total_ms")]
        out.append("super" if min(e) > LINEAR[1] else "sub" if max(e) < LINEAR[0] else "linear")
    return out


def _threads_line(rs, rs2, n2) -> str:
    """The second thread count against the first, by medians, 'within the spread' where
    their min-max ranges overlap."""
    by = {num(r["lights"]): r for r in rs2}
    parts = []
    for r in (rs[0], rs[-1]):
        o = by.get(num(r["lights"]))
        if o is None or num(o["cpu_total_ms"]) <= 0:
            continue
        overlap = (num(o["cpu_total_min_ms"]) <= num(r["cpu_total_max_ms"])
                   and num(r["cpu_total_min_ms"]) <= num(o["cpu_total_max_ms"]))
        parts.append(f"{num(r['cpu_total_ms']) / num(o['cpu_total_ms']):.2f}x the speed at "
                     f"{_k(r['lights'])}" + (" (within the spread)" if overlap else ""))
    return f" {n2} threads: {', '.join(parts)} (medians)." if parts else ""


def _bounded_buffers(rs) -> str:
    """The build buffers that stop growing with the lights: under 1.5x over the last two
    doublings (the lights 4x), bounded per cell or by a budget, not per light."""
    if len(rs) < 3:
        return ""
    a, b = _st(rs[-3]).get("buffer_bytes", {}), _st(rs[-1]).get("buffer_bytes", {})
    flat = [k for k in b if k != "lights" and k in a and b[k] < 1.5 * a[k] and b[k] > 64 << 10]
    if not flat:
        return ""
    return (" Bounded, not per light: " + ", ".join(
        f"{k} {_mib(a[k])} at {_k(rs[-3]['lights'])}, {_mib(b[k])} at {_k(rs[-1]['lights'])}"
        for k in flat) + " (a most per cell or a budget; the lights then share it).")


def growth_text(series, techs) -> list[str]:
    """Where each technique's time and memory stop growing linearly, and why (judged on
    each count's fastest builds and medians together, doubling_kinds)."""
    text = []
    for t in techs:
        keys = sorted(k for k in series if k[0] == t)
        if not keys or len(series[keys[0]]) < 2:
            continue
        rs = series[keys[0]]
        caches = _st(rs[0]).get("caches", {})
        tot = [num(r["cpu_total_min_ms"]) for r in rs]
        whole = math.log(tot[-1] / tot[0]) / math.log(num(rs[-1]["lights"]) / num(rs[0]["lights"]))
        kinds = doubling_kinds(rs)
        line = (f"{t} ({keys[0][1]} thread): {ms(tot[0])} at {_k(rs[0]['lights'])} lights, "
                f"{ms(tot[-1])} at {_k(rs[-1]['lights'])} (fastest builds; exponent "
                f"{whole:.2f} overall, per doubling {', '.join(f'{x:.2f}' for x in _exponents(tot))}).")
        if kinds[0] == "sub":
            a, b = _fixed_part(rs)
            end = next((j for j, k in enumerate(kinds) if k != "sub"), len(kinds))
            cells = _st(rs[0]).get("cells")
            line += f" Up to {_k(rs[end]['lights'])} lights it grows slower than the lights"
            if a > 0 and b > 0:
                line += (f": a fixed part of about {ms(a)} a frame (t = {a:.2f} ms + {b:.0f} ns "
                         f"a light over the two smallest counts)"
                         + (f", the per-cell work over its {int(cells):,} cells, which does not "
                            f"grow with the lights" if cells else ""))
            line += "."
        if "super" in kinds:
            j = kinds.index("super")
            line += (f" From {_k(rs[j]['lights'])} to {_k(rs[j + 1]['lights'])} it stops growing "
                     f"linearly ({tot[j + 1] / tot[j]:.2f}x for 2x the lights, fastest builds; the "
                     f"medians agree): "
                     + _why_superlinear(rs, j, caches) + ".")
        elif "sub" not in kinds:
            line += " No doubling departs from linear in both its fastest builds and its medians."
        if len(keys) > 1:
            line += _threads_line(rs, series[keys[1]], keys[1][1])
        mem = [_total_bytes(r) for r in rs]
        per = [m / num(r["lights"]) for m, r in zip(mem, rs)]
        flat = [j for j, x in enumerate(_exponents(mem)) if x < LINEAR[0]]
        line += f" Memory: {_mib(mem[0])} -> {_mib(mem[-1])} ({per[0]:.0f} -> {per[-1]:.0f} B a light)"
        if flat:
            j = flat[0]
            tiles = [_st(r).get("bit_tile_used") for r in rs]
            why = (f": its bit arrays stay within their budget by doubling the tile "
                   f"({tiles[j]} -> {tiles[-1]} px)" if tiles[-1] and tiles[-1] != tiles[0] else
                   ": a fixed part (per-cell records) outweighs the lights' share there"
                   if j == 0 else "")
            line += f", growing slower than the lights from {_k(rs[j]['lights'])}{why}."
        else:
            line += ", in proportion to the lights."
        line += _bounded_buffers(rs)
        text.append(line)
    return text


def growth_tables(series, techs) -> str:
    counts = sorted({num(r["lights"]) for rs in series.values() for r in rs})
    head = "| technique | threads | " + " | ".join(_k(n) for n in counts) + " | exponent per doubling |"
    out = ["CPU stage ms, median [min-max] over the builds, by light count:", "", head,
           "|---|---|" + "---|" * (len(counts) + 1)]
    for t in techs:
        for key in sorted(k for k in series if k[0] == t):
            by = {num(r["lights"]): r for r in series[key]}
            cells = [f"{num(by[n]['cpu_total_ms']):.3g} [{num(by[n]['cpu_total_min_ms']):.3g}-"
                     f"{num(by[n]['cpu_total_max_ms']):.3g}]" if n in by else "-" for n in counts]
            e = _exponents([num(r["cpu_total_ms"]) for r in series[key]])
            out.append(f"| {t} | {key[1]} | " + " | ".join(cells) + " | "
                       + ", ".join(f"{x:.2f}" for x in e) + " |")
    out += ["", "Bytes of the build's buffers (one thread's build; the lights' GPU rows and "
                "the structure's), by light count:", "",
            "| technique | buffer | " + " | ".join(_k(n) for n in counts) + " |",
            "|---|---|" + "---|" * len(counts)]
    for t in techs:
        keys = sorted(k for k in series if k[0] == t)
        if not keys:
            continue
        by = {num(r["lights"]): _st(r).get("buffer_bytes", {}) for r in series[keys[0]]}
        names = list(dict.fromkeys(k for b in by.values() for k in b))
        for name in names + ["all"]:
            cells = [(_mib(sum(by[n].values())) if name == "all" else _mib(by[n][name]))
                     if n in by and (name == "all" or name in by[n]) else "-" for n in counts]
            out.append(f"| {t} | {'**all**' if name == 'all' else name} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def growth_report(rows, out) -> tuple[str | None, list[str], str]:
    """(PNG name or None, text, markdown tables) of the growth series' rows (study
    "growth"): a log-log plot of time and bytes against lights, the exponent of each
    doubling, and where each technique stops growing linearly and why."""
    g = sel(rows, study=GROWTH_STUDY) if rows and "study" in rows[0] else []
    if not g:
        return None, [], ""
    techs = order(g, "technique")
    series = _series(g)
    png = growth_figure(series, out, techs)
    r0 = g[0]
    text = [f"The CPU stage alone (cull, sort, pack, bin, build; no upload) in {r0['scene']} at "
            f"{resolution(r0)}, the lights doubling from {_k(min(num(r['lights']) for r in g))} "
            f"to {_k(max(num(r['lights']) for r in g))}, every technique with a CPU build, one "
            f"thread and two in turn at each count. An exponent of 1 a doubling is linear "
            f"growth; below {LINEAR[0]} a fixed cost is being spread, above {LINEAR[1]} each "
            f"light costs more than at half the count; a doubling is called either only where "
            f"the fastest builds and the medians agree."] + growth_text(series, techs)
    return png, text, growth_tables(series, techs)


# ---- the build on the CPU and on the GPU (app.bench.gpu_build) ----------

GPU_BUILD_STUDY = "gpu_build"    # app.bench.gpu_build.STUDY
GPU_BUILD_CSV = "gpu_build.csv"  # app.bench.gpu_build.CSV


def gpu_build_rows(rows, out) -> list[dict]:
    """The "gpu_build" rows of results.csv, else those of out/gpu_build.csv."""
    got = sel(rows, study=GPU_BUILD_STUDY) if rows and "study" in rows[0] else []
    if got or out is None:
        return got
    from pathlib import Path
    from ..results import read_csv
    path = Path(out) / GPU_BUILD_CSV
    return sel(read_csv(path), study=GPU_BUILD_STUDY) if path.exists() else []


def _gpu_figures(r) -> tuple[float, float, dict]:
    """(GPU build ms, its ratio to the CPU stage, ms by pass) of a row: fastest samples."""
    s = _st(r)
    g, c = num(s.get("gpu_build_min_ms", math.nan)), num(r["cpu_total_min_ms"])
    return g, g / c if c > 0 else math.nan, s.get("passes", {})


def gpu_build_report(rows) -> tuple[list[str], str]:
    """(text, markdown table): per technique and light count the CPU stage against the GPU
    build as a ratio, and which GPU pass takes its time at the largest count, and how much."""
    if not rows:
        return [], ""
    techs = order(rows, "technique")
    r0 = rows[0]
    text = [f"Each technique's structures built by the CPU stage (numba, one thread) and by "
            f"compute passes (`--build gpu`, the same buffers bit for bit) in {r0['scene']} at "
            f"{resolution(r0)}, fastest of {int(num(r0['samples']))} samples. On llvmpipe the "
            f"passes run on the same cores as the CPU stage: the ratio says what the GPU "
            f"build costs on a CPU, not what it costs on a GPU."]
    table = ["| technique | lights | visible | CPU stage ms | GPU build ms | GPU / CPU | "
             "GPU build by pass, ms |", "|---|---:|---:|---:|---:|---:|---|"]
    for t in techs:
        rs = sorted(sel(rows, technique=t), key=lambda r: num(r["lights"]))
        figs = [_gpu_figures(r) for r in rs]
        for r, (g, ratio, passes) in zip(rs, figs):
            table.append(f"| {t} | {int(num(r['lights'])):,} | {int(num(r['visible'])):,} | "
                         f"{num(r['cpu_total_min_ms']):.3g} | {g:.3g} | {ratio:.3g} | "
                         + ", ".join(f"{k} {v:.3g}" for k, v in sorted(passes.items(), key=lambda kv: -kv[1]))
                         + " |")
        g, ratio, passes = figs[-1]
        top = max(passes, key=passes.get) if passes else None
        lo, hi = min(f[1] for f in figs), max(f[1] for f in figs)
        line = (f"{t}: the GPU build takes {lo:.3g}-{hi:.3g}x the CPU stage's time from "
                f"{_k(rs[0]['lights'])} to {_k(rs[-1]['lights'])} lights" if len(rs) > 1 else
                f"{t}: the GPU build takes {lo:.3g}x the CPU stage's time at {_k(rs[0]['lights'])} lights")
        if top and g > 0:
            line += (f"; at {_k(rs[-1]['lights'])} its largest part is {top} "
                     f"({100 * passes[top] / g:.0f}% of {ms(g)})")
        text.append(line + ".")
    return text, "\n".join(table)


# ---- the CPU stage against plain single-threaded C ---------------------

C_REFERENCE_STUDY = "c_reference"    # app.bench.c_reference.compare.STUDY
ISSUE_C_MS = {"hybrid": 6.7, "clustered": 4.6}   # the issue's C figures (docs/cpu_stage.md)


def c_reference_report(rows) -> tuple[list[str], str]:
    """(text, markdown table): per technique, count and numba thread count, the C and our
    stage (interleaved frame by frame, so the ratio holds while the machine's speed moves)."""
    if not rows:
        return [], ""
    r0 = rows[0]
    text = [f"Our CPU stage (numba) and `app/bench/c_reference/hybrid_ref.c`, the same stage as "
            f"plain single-threaded scalar C (the same outputs bit for bit), run interleaved "
            f"frame by frame in {r0['scene']} at {resolution(r0)}, {int(num(r0['samples']))} "
            f"frames each: ratio = ours / C (under 1: ours is faster)."]
    table = ["| technique | lights | visible | numba threads | C ms, min / median | ours ms, "
             "min / median | ratio, min (median) | outputs |", "|---|---:|---:|---:|---:|---:|---:|---|"]
    for t in order(rows, "technique"):
        rs = sorted(sel(rows, technique=t), key=lambda r: (num(r["lights"]), _st(r).get("threads", 1)))
        for r in rs:
            s = _st(r)
            table.append(f"| {t} | {int(num(r['lights'])):,} | {int(num(r['visible'])):,} | "
                         f"{s.get('threads', 1)} | {s['c_min_ms']:.3g} / {s['c_ms']:.3g} | "
                         f"{num(r['cpu_total_min_ms']):.3g} / {num(r['cpu_total_ms']):.3g} | "
                         f"{s['ratio_min']:.2f}x ({s['ratio_median']:.2f}x) | "
                         f"{'identical' if s['identical'] else 'DIFFER'} |")
        top = [r for r in rs if num(r["lights"]) == max(num(x["lights"]) for x in rs)]
        parts = [f"{_st(r)['ratio_min']:.2f}x" + (" the C's time" if j == 0 else "") +
                 f" on {_st(r).get('threads', 1)} thread{'s' if _st(r).get('threads', 1) > 1 else ''}"
                 for j, r in enumerate(top)]
        line = f"{t} at {_k(top[0]['lights'])} lights: ours takes " + ", ".join(parts) + " (min)"
        if t in ISSUE_C_MS and num(top[0]["lights"]) == 65536:
            best = min(num(r["cpu_total_min_ms"]) for r in top)
            line += (f"; against the issue's C figure ({ISSUE_C_MS[t]} ms, a faster program than "
                     f"this C) our fastest is {best / ISSUE_C_MS[t]:.2f}x ({ms(best)})")
        text.append(line + ".")
    return text, "\n".join(table)
