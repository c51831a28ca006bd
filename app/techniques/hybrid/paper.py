"""hybrid: its paper's figures and prose beside a benchmark run's, for the report
(report_notes, app.report.notes)."""
from __future__ import annotations

import numpy as np
import json
from cpu_prep import layouts

from ..blocks import study_notes


def report_notes(technique, rows):
    """Per wave path: the waves, their scalar iterations and node visits, against the
    unspecialised loop (app/report/notes.py)."""
    return _notes(rows)


def _notes(rows) -> tuple[str, str]:
    def stats(sub):
        out = {}
        for r in sub:
            for k, v in json.loads(r.get("stats") or "{}").items():
                out.setdefault(k, []).append(v)
        return {k: float(np.mean(v)) for k, v in out.items()}

    text = ["The paper's three wave paths, classified by listing 2's choice per cell (tree "
            "paper figure 3; mean over the camera path):", "",
            "| scene, lights | cells list / tree | waves list / tree / mixed | scalar iterations "
            "per wave, list / tree / mixed | nodes visited per pixel, list / tree / mixed |",
            "|---|---|---|---|---|"]
    path = [r for r in rows if r["study"] == "path"]
    for key in dict.fromkeys((r["scene"], int(r["lights"])) for r in path):
        s = stats([r for r in path if (r["scene"], int(r["lights"])) == key])
        if "waves_list" not in s:
            continue
        c = list(layouts.CASES.values())
        text.append(f"| {key[0]}, {key[1]} | {s.get('lists', 0):.0f} / {s.get('trees', 0):.0f} | "
                    + " / ".join(f"{s[f'waves_{n}']:.0f}" for n in c) + " | "
                    + " / ".join(f"{s[f'iterations_{n}']:.3g}" for n in c) + " | "
                    + " / ".join(f"{s[f'nodes_{n}']:.3g}" for n in c) + " |")
    study = [r for r in rows if r["study"] == "specialised"]
    by = {bool(r["specialised"]): stats([r]) for r in study}
    if True in by and False in by:
        r0 = study[0]
        text += ["", f"Specialised paths against the one general traversal ({r0['scene']}, "
                 f"{int(r0['lights'])} lights, frame {int(r0['frame'])}):", "",
                 "| path | waves | scalar iterations, specialised / general | nodes per pixel, "
                 "specialised / general |", "|---|---|---|---|"]
        for n in layouts.CASES.values():
            a, g = by[True], by[False]
            text.append(f"| {n} | {a.get(f'waves_{n}', 0):.0f} | {a.get(f'iterations_{n}', 0):.3g} / "
                        f"{g.get(f'iterations_{n}', 0):.3g} | {a.get(f'nodes_{n}', 0):.3g} / "
                        f"{g.get(f'nodes_{n}', 0):.3g} |")
        text.append(f"\n{a.get('waves_shared_tree', 0):.0f} waves read their one tree from shared "
                    f"memory.  The GPU time of the two is in the option study above "
                    f"(`specialised`).")
    builds = study_notes(rows)
    if builds:
        text += ["", "The tree cells' build (`tree_build`):", "", builds]
    return "wave paths (tree paper 3.4)", "\n".join(text)
