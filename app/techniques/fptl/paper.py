"""fptl: its paper's figures and prose beside a benchmark run's, for the report
(report_notes, app.report.notes)."""
from __future__ import annotations

from . import VARIANTS, list_words


def report_notes(technique, rows):
    """The chapter's figures beside this run's (app/report/notes.py)."""
    return _notes(rows)


def _bytes_note(rows) -> list[str]:
    """The bytes shading reads per lit tile (stat shade_bytes_per_tile, the chapter's
    variant: per-tile fine lists) per scene and index format, beside the chapter's 32 B."""
    import json
    by: dict[tuple, list] = {}
    for r in rows:
        st = json.loads(r["stats"]) if r.get("stats") else {}
        if "shade_bytes_per_tile" not in st or int(float(r.get("fptl_variant") or 0)) != 0:
            continue
        by.setdefault((r["scene"], int(st["index_bits"])), []).append(st)
    if not by:
        return []
    parts = []
    for (scene, bits), sts in by.items():
        m = lambda k: sum(s[k] for s in sts) / len(sts)
        parts.append(f"{scene} ({bits}-bit indices, {list_words(bits) * 4} B a tile stored) "
                     f"{m('shade_bytes_per_tile'):.1f} B ({m('shade_list_bytes_per_tile'):.1f} of list "
                     f"words, {m('shade_spill_bytes_per_tile'):.1f} of spill heads and spill)")
    return ["The chapter stores a tile's list in 32 bytes (eight R10G10B10A2 blocks, the count "
            "in their 2-bit fields: 1 bit a pixel), all that lighting pulls from the tile.  This "
            "run's shading reads its lists the same way, the length and the spill flag in the "
            "words themselves (at 10-bit indices exactly the 32 B; past 1,024 visible lights a "
            "count word and the index words filled), plus, for lists past 24, the spill the "
            "chapter does not have; bytes shading reads per lit tile, mean over the frames: "
            + "; ".join(parts) + ".", ""]


def _notes(rows) -> tuple[str, str]:
    import json
    text = ["The chapter (1920x1080 interior, AMD GCN): coarse lists cost 0.5 ms and lighting "
            "5.4 ms; fine pruning costs 1.7 ms and lighting drops to 1.4 ms; its heat maps "
            "(figures 2.4-2.6) show pruning lowering the count in almost every tile.", ""]
    text += _bytes_note(rows)
    study = [r for r in rows if r["study"] == "fptl_variant"]
    if study:
        text += [f"This run's variant study ({study[0]['scene']}, {int(study[0]['lights'])} lights):",
                 "", "| variant | list building ms | shading ms | evaluated/px | coarse/tile | "
                 "pruned/tile | shading reads B/tile | culling bytes |", "|---|---|---|---|---|---|---|---|"]
        for r in sorted(study, key=lambda r: int(r["fptl_variant"])):
            st = json.loads(r["stats"]) if r.get("stats") else {}
            build_ms = float(r.get("gpu_cull_ms") or 0)      # light_aabb + fptl_lists
            text.append(f"| {VARIANTS[int(r['fptl_variant'])]} | {build_ms:.3g} | "
                        f"{float(r.get('gpu_shade_ms') or 0):.3g} | {float(r['evaluated_pp']):.3g} | "
                        f"{st.get('coarse_per_tile', 0):.3g} | {st.get('pruned_per_tile', 0):.3g} | "
                        f"{st.get('shade_bytes_per_tile', 0):.3g} | {int(r['bytes_culling']):,} |")
    path = [r for r in rows if r["study"] == "path"]
    for scene in dict.fromkeys(r["scene"] for r in path):
        st = [json.loads(r["stats"]) for r in path if r["scene"] == scene and r.get("stats")]
        coarse = sum(s.get("coarse_entries", 0) for s in st)
        pruned = sum(s.get("pruned_entries", 0) for s in st)
        over = sum(s.get("pruned_overflow_cells", 0) + s.get("coarse_overflow_tiles", 0) for s in st)
        if coarse:
            text.append(f"\n{scene} (every path frame): fine pruning keeps {pruned / coarse:.1%} of "
                        f"the coarse entries ({pruned:,} of {coarse:,}); {over:,} tile lists "
                        f"passed a cap (64 coarse or 24 pruned) and were shaded exactly from the "
                        f"spill.")
    return "what the chapter measures", "\n".join(text)
