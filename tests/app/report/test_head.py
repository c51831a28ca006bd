"""The report's head: where a preset leaves the wave replay out of some rendered rows, it says
which rows have modelled columns."""
from app.report import _modelled_rows


def _row(study, frame, modelled=True):
    return {"study": study, "frame": str(frame), "model_version": "3" if modelled else ""}


def test_the_head_names_the_rows_a_preset_modelled():
    rows = [_row("path", 0), _row("path", 1, False), _row("path", 2, False), _row("tile", 0),
            _row("cutoff", 0, False), _row("caps", 0, False)]
    text = " ".join(_modelled_rows(rows))
    assert "2 of the 6 rendered rows" in text and "path frame 0 " in text
    assert "but caps and cutoff" in text


def test_a_run_that_models_every_row_says_nothing_of_it():
    assert _modelled_rows([_row("path", 0), _row("path", 1), _row("cutoff", 0)]) == []
