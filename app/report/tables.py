"""The report's tables: shading time against the floor, and the hardware-neutral summary of
the camera-path study."""
from __future__ import annotations

from .aggregate import aggregate_path
from .common import ms, order, sel, times
from .spread import below, lowest


def floor_table(rows, roles) -> tuple[str, list[str]]:
    """Each technique's shading time as a position between the reference (0%) and the
    floor (100%)."""
    agg = aggregate_path(rows)
    techs = order(sel(rows, study="path"), "technique")
    lines = ["| scene, lights | " + " | ".join(techs) + " |", "|---" * (len(techs) + 1) + "|"]
    text = []
    for key, d in agg.items():
        b, f = d.get(roles.reference), d.get(roles.floor)
        span = b["shade"].med - f["shade"].med if b and f else 0.0
        pos = lambda v: 100 * (b["shade"].med - v) / span
        cells = []
        for t in techs:
            if t not in d:
                cells.append("-")
                continue
            cells.append(ms(d[t]["shade"].med) + (f" ({pos(d[t]['shade'].med):.1f}%)" if span > 0 else ""))
        lines.append(f"| {key[0]}, {key[1]} | " + " | ".join(cells) + " |")
        others = {t: v["shade"] for t, v in d.items() if t not in (roles.reference, roles.floor)}
        if span > 0 and others:
            best, rivals = lowest(others)
            s = (f"{key[0]}, {key[1]} lights: {best} shades in {times(others[best].med / f['shade'].med)} "
                 f"the floor's time ({pos(others[best].med):.1f}% of the way from {roles.reference} "
                 f"to {roles.floor})")
            if rivals:
                s += f"; within spread of {', '.join(rivals)}"
            if below(others[best], f["shade"]):
                s += (f"; {best} shades faster than the floor beyond spread: the floor bounds the "
                      f"lights evaluated, not the time, and its per-pixel lists are read "
                      f"incoherently across a wave where {best}'s lists are shared")
            elif not below(f["shade"], others[best]):
                s += f"; the floor is within spread of {best}"
            text.append(s + ".")
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
                         f"{v['bytes'] / 1024:.0f} | {v['cpu'].med:.3g} | {v['gpu'].med:.3g} | "
                         f"{v['mism']:.0f} | {v['err']:.2g} |")
    return "\n".join(lines)
