"""The model held to a real GPU: rank agreement, ratios and the committed record."""
import json
import shutil

import numpy as np

from app.model import cost
from app.report import gpu_record

H200 = next(g for g in cost.GPUS if g.key == "h200")


def _row(technique, measured, modelled, scene="arena", frame="0"):
    return {"study": "path", "scene": scene, "lights": "65536", "frame": frame,
            "technique": technique, "gpu_lighting_ms": str(measured),
            "model_h200_lighting_ms": str(modelled), "model_version": cost.MODEL_VERSION}


def test_pairs_count_only_measured_gaps_past_the_tie_and_a_reversal_past_it():
    rows = [_row("a", 1.0, 1.0), _row("b", 2.0, 0.5), _row("c", 2.05, 3.0)]
    # measured apart: (a, b) and (a, c); b and c are a tie.  The model reverses (a, b).
    assert gpu_record.rank_agreement(rows, H200) == (0, 1, 1, 2)
    rows[1]["model_h200_lighting_ms"] = "0.95"          # within 10% of a's: not a reversal
    assert gpu_record.rank_agreement(rows, H200) == (1, 1, 2, 2)


def test_ratios_are_geometric_means_per_technique():
    rows = [_row("a", 2.0, 1.0), _row("a", 8.0, 1.0, scene="city"), _row("b", 1.0, 2.0)]
    r = gpu_record.ratios(rows, H200)
    assert np.isclose(r["a"], 4.0) and np.isclose(r["b"], 0.5)


def test_rows_without_a_model_are_not_measured_against_it():
    """A preset that models the first frame of each path alone (model_frames) leaves the
    later frames' modelled cells blank: those rows are no pair and no ratio."""
    rows = [_row("a", 1.0, 1.0), _row("b", 2.0, 2.0), _row("a", 1.0, 1.0, frame="1"),
            {**_row("b", 9.0, 1.0, frame="1"), "model_h200_lighting_ms": "", "model_version": ""}]
    kept = gpu_record.measured_rows(rows)
    assert [r["frame"] for r in kept] == ["0", "0", "1"]
    assert gpu_record.ratios(kept, H200) == {"a": 1.0, "b": 1.0}


def test_the_committed_record_is_a_real_gpu_run_and_reads_back():
    rec = gpu_record.record()
    assert rec is not None and "NVIDIA" in rec.renderer
    assert 0 < rec.low <= rec.high and 0 < rec.alike <= rec.pairs
    text = rec.sentence()
    assert rec.renderer in text and f"{rec.alike} of the {rec.pairs}" in text


def test_no_record_where_the_folder_lacks_one_or_holds_a_software_run(tmp_path):
    assert gpu_record.record(tmp_path) is None
    for name in ("results.csv", "run.json"):
        shutil.copy(gpu_record.RECORD / name, tmp_path / name)
    info = json.loads((tmp_path / "run.json").read_text())
    (tmp_path / "run.json").write_text(json.dumps(dict(info, software=True)))
    assert gpu_record.record(tmp_path) is None


def test_pair_error_is_the_median_miss_of_the_ratios():
    rows = [_row("a", 1.0, 1.0), _row("b", 2.0, 2.0), _row("c", 4.0, 1.0)]
    # ratios measured / modelled: (a, b) 0.5 / 0.5, (a, c) 0.25 / 1, (b, c) 0.5 / 2
    assert np.isclose(gpu_record.pair_error(rows, H200), 4.0)
    assert np.isclose(gpu_record.pair_error(rows[:2], H200), 1.0)
