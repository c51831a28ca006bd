"""Tree paper figure 4 and section 4.1: the CPU stage alone vs light count, stacked by step,
and each step's share against the paper's."""
from __future__ import annotations

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
