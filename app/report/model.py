"""The cost model's own section: what it counts (the instructions of every step it prices,
counted from each technique's programs: app.model.counts), what it assumes (the named list
app.model.cost.ASSUMED, with sources), and which of the validation section's verdicts move
when one assumption moves by 30% (the sensitivity table).

Every number here is read back from the rows' `waves` column (the figures and the counts
that made each modelled time), so the section re-derives the model's times rather than
quoting them (predict.from_json)."""
from __future__ import annotations

import json
import math

from ..model import cost, predict
from ..results import option_columns
from .common import num

SENSITIVITY = 0.30          # each assumption moved by -30% and +30%, one at a time
COLUMNS = ("", "T", "÷", "R")   # alu slots, transcendentals, integer divisions, reductions


def fmt(v) -> str:
    """A counted step: '40 + 3T + 2÷' (alu, transcendentals, integer divisions, reductions)."""
    parts = [f"{x:g}{c}" for x, c in zip(v, COLUMNS) if x]
    return " + ".join(parts) if parts else "0"


def _ops_of(row, pass_name="shade"):
    if not row.get("waves"):
        return None
    d = json.loads(row["waves"])
    width = "32" if "32" in d else next(iter(d), None)
    f = d.get(width, {}).get(pass_name) if width else None
    return (f.get("ops"), tuple(f.get("programs", ()))) if f and f.get("ops") else None


def _label(row) -> str:
    """The options in which a row differs from its technique's defaults."""
    from ..techniques import REGISTRY
    t = REGISTRY.get(row["technique"])
    defaults = t.Options().as_dict() if t else {}
    same = lambda a, b: (num(a) == num(b)) if not (math.isnan(num(a)) or math.isnan(num(b))) \
        else str(a) == str(b)
    diff = [f"{c}={row[c]}" for c in option_columns()
            if c in defaults and row.get(c, "") != "" and not same(row[c], defaults[c])]
    return ", ".join(diff) or "defaults"


STEP_ORDER = ("cell", "node", "lds_node", "load", "word", "light", "mask_light", "set_bit")


def counts_table(rows) -> str:
    """Per technique and per variant whose shading program differs: the counted steps."""
    seen, lines = set(), []
    for r in rows:
        got = _ops_of(r)
        if not got:
            continue
        ops, programs = got
        t = r["technique"]
        sig = (t, json.dumps(ops, sort_keys=True))
        if sig in seen:
            continue
        seen.add(sig)
        steps = [f"{k} {fmt(ops[k])}" for k in STEP_ORDER if k in ops]
        shapes = [s for s in ("point", "spot", "capsule", "box") if f"test:{s}" in ops]
        tests = " / ".join(f"{s} {fmt(ops[f'test:{s}'])}" for s in shapes)
        shades = " / ".join(f"{s} {fmt(ops[f'shade:{s}'])}" for s in shapes)
        lines.append(f"| {t} | {_label(r)} | {', '.join(programs)} | "
                     f"{'; '.join(steps)} | {tests} | {shades} | "
                     f"{fmt(ops['ggx']) if 'ggx' in ops else ''} | {fmt(ops.get('wave', []))} |")
    if not lines:
        return ""
    head = ["| technique | options | program | steps (one issued iteration) | affects test "
            "(point / spot / capsule / box) | shading of an affecting light | + GGX | "
            "per wave |", "|---|---|---|---|---|---|---|---|"]
    return "\n".join(head + lines)


def cull_table(rows) -> str:
    """The culling passes' counted steps, per technique (their first row)."""
    lines, seen = [], set()
    for r in rows:
        if not r.get("waves") or r["technique"] in seen:
            continue
        d = json.loads(r["waves"])
        passes = d.get("32") or next(iter(d.values()), {})
        cells = []
        for name, f in passes.items():
            ops = f.get("ops") or {}
            kinds = [k for k in ops if k not in ("wave", "ggx") and ":" not in k and
                     f.get(f"{k}_issued")]
            if name != "shade" and kinds:
                cells.append(f"{name} ({', '.join(f.get('programs', []))}): "
                             + "; ".join(f"{k} {fmt(ops[k])}" for k in kinds))
        if cells:
            seen.add(r["technique"])
            lines.append(f"| {r['technique']} | " + "<br>".join(cells) + " |")
    return "\n".join(["| technique | culling passes: counted steps |", "|---|---|"] + lines) \
        if lines else ""


def assumptions_text() -> list[str]:
    return [f"`{k}` = {a.value:g}: {a.what} ({a.source})" for k, a in cost.ASSUMED.items()]


def remodel(row) -> dict | None:
    """The row's modelled times again from its figures, under the assumptions in force:
    {gpu key: {"cull", "shade", "lighting", "bound"}}."""
    if not row.get("waves"):
        return None
    figures = predict.from_json(row["waves"])
    out = {}
    for key, m in predict.modelled(figures, [g for g in cost.GPUS if g.wave in figures]).items():
        out[key] = dict(m, lighting=m["cull"] + m["shade"])
    return out


def accessor(rows):
    """ms(row, gpu key, part) from the rows' figures under the assumptions now in force
    (part: cull, shade or lighting); cached per row for one setting."""
    cache = {}

    def ms(row, key, part="lighting"):
        i = id(row)
        if i not in cache:
            cache[i] = remodel(row)
        m = cache[i]
        return m[key][part] if m and key in m else math.nan
    return ms


def stored(row, key, part="lighting") -> float:
    return num(row.get(f"model_{key}_{part}_ms"))


def sensitivity(rows, judge) -> tuple[str, list[str]]:
    """Each verdict of `judge(rows, ms) -> [(claim id, text, verdict)]` re-judged with every
    assumption moved by -30% and +30% one at a time: the table, and the fragile claims (a
    verdict that changes) in words."""
    base = {cid: v for cid, _, v in judge(rows, accessor(rows))}
    if not base:
        return "", []
    flips, cols = {}, []
    for name, a in cost.ASSUMED.items():
        for sign in (-1, 1):
            value = a.value * (1 + sign * SENSITIVITY)
            with cost.assume(**{name: value}):
                got = {cid: v for cid, _, v in judge(rows, accessor(rows))}
            col = f"{name} {'-' if sign < 0 else '+'}{SENSITIVITY:.0%}"
            cols.append(col)
            for cid, v in got.items():
                if v != base.get(cid):
                    flips.setdefault(cid, {})[col] = v
    head = ["| claim | verdict | " + " | ".join(cols) + " |", "|---|---|" + "---|" * len(cols)]
    body = [f"| {cid} | {v} | " + " | ".join(flips.get(cid, {}).get(c, "=") for c in cols) + " |"
            for cid, v in base.items()]
    words = [f"**fragile**: {cid} ({base[cid]}) becomes " +
             ", ".join(f"{v} at {c}" for c, v in f.items()) for cid, f in flips.items()]
    if not flips:
        words = ["No verdict changes when any one assumption moves by 30%."]
    return "\n".join(head + body), words


def judge(rows, ms):
    """The validation section's claims under accessor `ms`: (id, text, verdict)."""
    from .validation import claims
    return [(c.id, c.text, c.verdict) for c in claims(rows, ms)]


def model_section(rows) -> tuple[list[str], str]:
    """The section's bullets and tables."""
    table, cull = counts_table(rows), cull_table(rows)
    if not table:
        return [], ""
    sens, fragile = sensitivity(rows, judge)
    text = [f"Model v{cost.MODEL_VERSION} (app/model/cost.py).  Its GPU figures are the vendors' "
            "public specifications; the instructions of every step it prices are counted from "
            "the SPIR-V of the program that runs the step (glslang, unoptimised; the rule in "
            "app/model/spirv.py, the steps marked `// priced:` in the shaders), per technique "
            "and per variant whose code differs; the rest is the named list below, and nothing "
            "is fitted.  A count reads: issue slots, T transcendentals (at the GPU's special-"
            "function rate), ÷ integer divisions, R wave reductions (priced by the assumptions).",
            "The assumptions, the only numbers that are neither a published figure nor counted:",
            *[f"  - {t}" for t in assumptions_text()]]
    if sens:
        text += [f"Sensitivity: every verdict of the validation section judged again from the "
                 f"rows' own figures with each assumption moved by -{SENSITIVITY:.0%} and "
                 f"+{SENSITIVITY:.0%}, one at a time (the table below: '=' where the verdict "
                 f"holds).  A verdict that changes is fragile: it rests on that assumption.",
                 *fragile]
    tables = "The shading passes' counted steps:\n\n" + table + (
        "\n\nThe culling passes':\n\n" + cull if cull else "")
    if sens:
        tables += "\n\nThe verdicts under each assumption moved:\n\n" + sens
    return text, tables
