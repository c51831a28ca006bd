"""The report's lead figure (app.report.tradeoff) on hand-made rows: the Pareto front, the
advice naming a step only beyond the measured spread, the figure written with its panels."""
import json
import re

from app.report.common import Colors, Roles
from app.report.spread import Spread
from app.report.tradeoff import advice, choices, fig_tradeoff, front, gather
from app.results import option_specs

ROLES = Roles.from_registry()
POLICIES = option_specs()["cap_policy"].choices


def row(study, technique, cost, err, flip=None, spread=0.1, samples=5, **kw):
    r = {"study": study, "scene": "arena", "lights": 256.0, "visible": 200.0, "width": 64.0,
         "height": 36.0, "technique": technique, "cutoff": 0.0, "samples": float(samples),
         "frame_cost_ms": cost, "frame_cost_min_ms": cost * (1 - spread),
         "frame_cost_max_ms": cost * (1 + spread), "image_error": err,
         "image_flip": err / 2 if flip is None else flip, "stochastic": float("nan"),
         "cap_policy": float("nan"), "stats": "{}", "mismatch_count": 0.0, "mismatch_hash": 0.0}
    r.update(kw)
    return r


def cap_row(technique, policy, cost, err, lost, **kw):
    return row("caps", technique, cost, err, cap_policy=float(POLICIES.index(policy)),
               stats=json.dumps({"lost_pixels": lost}), **kw)


def rows_set(spread=0.1, samples=5):
    k = dict(spread=spread, samples=samples)
    return [
        row("cutoff", ROLES.reference, 100.0, 0.0, flip=0.0, cutoff=-1.0, **k),
        row("cutoff", "tiled", 10.0, 0.20, cutoff=256.0, **k),
        row("cutoff", "tiled", 20.0, 0.05, cutoff=4096.0, **k),
        row("cutoff", "clustered", 8.0, 0.20, cutoff=256.0, **k),     # cheaper, same error
        row("cutoff", "clustered", 30.0, 0.04, cutoff=4096.0, **k),   # dominated (same error)
        row("cutoff", ROLES.floor, 1.0, 0.01, cutoff=4096.0, **k),    # left out
        row("cutoff", "tiled", 12.0, 0.10, cutoff=0.0, stochastic=256.0, **k),
        cap_row("tiled", "none", 15.0, 0.08, 0, **k),
        cap_row("tiled", "urp-16", 5.0, 0.9, 400, **k),
    ]


def test_the_front_on_hand_made_rows():
    g = gather(rows_set(), [], ROLES)[("arena", 256)]
    assert ROLES.floor not in {p.technique for p in g["points"]}
    assert g["reference"]["cutoff"] == -1.0
    assert {p.kind for p in g["points"]} == {"cutoff", "stochastic", "radii", "cap"}
    labels = [p.label for p in front(g["points"], "rmse")]
    assert labels == ["tiled, urp-16", "clustered, cutoff 1/256", "tiled, stochastic 1/256",
                      "tiled, scene radii", "tiled, cutoff 1/4096", "clustered, cutoff 1/4096"]
    # the policies without a row are named as skipped
    assert set(g["skipped"]) == set(POLICIES) - {"none", "urp-16"}


def test_choices_step_only_beyond_the_spread():
    pts = gather(rows_set(spread=0.1), [], ROLES)[("arena", 256)]["points"]
    got = [p.label for p, _ in choices(pts, "rmse")]
    # tiled 1/256 has clustered's error at a cost not lower beyond spread: left out; each
    # other step buys less error for a cost beyond the cheaper one's spread
    assert got == ["tiled, urp-16", "clustered, cutoff 1/256", "tiled, stochastic 1/256",
                   "tiled, scene radii", "tiled, cutoff 1/4096", "clustered, cutoff 1/4096"]
    # with a wide spread every cost overlaps: the most accurate dominates all
    wide = gather(rows_set(spread=0.9), [], ROLES)[("arena", 256)]["points"]
    assert [p.label for p, _ in choices(wide, "rmse")] == ["clustered, cutoff 1/4096"]
    text = advice("arena", 256, wide, "rmse")
    assert "beyond spread" not in text and "budget of" not in text
    assert "clustered, cutoff 1/4096" in text


def test_equal_errors_are_one_choice_the_cheaper():
    pts = gather(rows_set(), [], ROLES)[("arena", 256)]["points"]
    by = {p.label: p for p in pts}
    by["tiled, cutoff 1/256"].rmse = by["clustered, cutoff 1/256"].rmse * 1.001
    by["tiled, cutoff 1/256"].cost = Spread(8.5, 7.65, 9.35, 5)     # overlaps clustered's
    labels = [p.label for p, _ in choices(pts, "rmse")]
    assert "clustered, cutoff 1/256" in labels and "tiled, cutoff 1/256" not in labels
    text = advice("arena", 256, pts, "rmse")
    assert "or tiled, cutoff 1/256" in text


def test_one_sample_names_no_budget():
    pts = gather(rows_set(samples=1), [], ROLES)[("arena", 256)]["points"]
    text = advice("arena", 256, pts, "flip")
    assert "one timing sample" in text and "beyond spread" not in text


def test_advice_claims_each_step_beyond_spread():
    pts = gather(rows_set(spread=0.05), [], ROLES)[("arena", 256)]["points"]
    text = advice("arena", 256, pts, "rmse")
    steps = re.findall(r"budget of ([0-9.]+) ms", text)
    assert len(steps) == len(choices(pts, "rmse")) - 1 > 0
    # every named step's cost lies beyond the previous choice's spread
    ch = [p for p, _ in choices(pts, "rmse")]
    assert all(a.cost.hi < b.cost.lo for a, b in zip(ch, ch[1:]))


def test_figure_written_with_a_temporal_panel(tmp_path):
    rows = rows_set()
    trows = [{"scene": "arena", "lights": 256.0, "kind": "cap", "technique": "tiled",
              "policy": "urp-16", "cutoff": 0.0, "temporal_error_pct": e} for e in (3.0, 5.0)]
    trows += [{"scene": "arena", "lights": 256.0, "kind": "technique", "technique": "tiled",
               "policy": "none", "cutoff": 0.0, "temporal_error_pct": 0.5}]
    # stochastic culling's temporal configuration (brute, a new draw a frame) at its budget
    trows += [{"scene": "arena", "lights": 256.0, "kind": "stochastic", "technique": "brute",
               "policy": "none", "cutoff": 0.0, "stochastic": n, "temporal_error_pct": e}
              for n, e in ((256.0, 7.0), (4096.0, 9.0))]
    colors = Colors([r["technique"] for r in rows], ROLES)
    png, text = fig_tradeoff(rows, trows, tmp_path, colors, ROLES)
    assert png == "tradeoff.png" and (tmp_path / png).stat().st_size > 10_000
    g = gather(rows, trows, ROLES)[("arena", 256)]
    # the cap's figure holds for every technique under it; an exact technique's is its own
    assert {p.label: p.temporal for p in g["points"] if p.temporal == p.temporal} == \
        {"tiled, urp-16": 4.0, "tiled, scene radii": 0.5, "tiled, stochastic 1/256": 7.0}
    assert "exact on the lights it kept" in "\n".join(text)
    assert "drop none of the 200 visible lights" in "\n".join(text)
    joined = "\n".join(text)
    assert "temporal error" in joined and "FLIP" in joined and "relative RMSE" in joined
    assert "urp-16 400 of 2304" in joined
    # no rows of either study: no figure
    assert fig_tradeoff([r for r in rows if r["study"] == "path"], [], tmp_path, colors, ROLES) == (None, [])


def test_a_scene_without_temporal_rows_gets_a_note_not_a_panel(tmp_path):
    """The temporal series runs in one scene; the cutoff study in two: the other scene's
    temporal panel says it has none (an empty log axis stopped the report)."""
    rows = rows_set() + [dict(r, scene="city") for r in rows_set()]
    trows = [{"scene": "arena", "lights": 256.0, "kind": "technique", "technique": "tiled",
              "policy": "none", "cutoff": 0.0, "temporal_error_pct": 0.5}]
    colors = Colors([r["technique"] for r in rows], ROLES)
    png, text = fig_tradeoff(rows, trows, tmp_path, colors, ROLES)
    assert png == "tradeoff.png" and (tmp_path / png).stat().st_size > 10_000
    assert any("city" in t for t in text)
