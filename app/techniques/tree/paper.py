"""tree: its paper's figures and prose beside a benchmark run's, for the report
(report_notes, app.report.notes)."""
from __future__ import annotations

from ..blocks import study_notes


def report_notes(technique, rows):
    """The tree_build and shared_tree studies' per-pixel work and costs (app/report/notes.py)."""
    return "tree builds (paper 3.2) and the shared-memory tree (3.4)", study_notes(rows)
