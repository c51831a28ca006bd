"""The key table (app.window.keys.KEYS) is the one place keys are written: the key names,
the key codes, the HUD's help line, the panel's list, the README's sentence and the
dispatch all come from it.  No GL."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from app.window import keys
from app.window.hud import HELP as HUD_HELP

ROOT = Path(__file__).resolve().parents[3]


class Recorder:
    """A stand-in window: every handler records (handler, key name)."""

    def __init__(self):
        self.calls = []

    def __getattr__(self, handler):
        return lambda name: self.calls.append((handler, name))


def test_every_key_dispatches_to_its_rows_handler():
    assert len(keys.KEY_NAMES) == sum(len(row.names) for row in keys.KEYS)     # no key in two rows
    target = Recorder()
    for name in keys.KEY_NAMES:
        keys.dispatch(target, name)
    assert target.calls == [(row.handler, n) for row in keys.KEYS for n in row.names]


def test_every_handler_is_a_method_of_the_window():
    from app.window.app import LabWindow
    missing = [row.handler for row in keys.KEYS if not callable(getattr(LabWindow, row.handler, None))]
    assert not missing
    # and no attribute of the window shadows a handler
    tree = ast.parse((ROOT / "app" / "window" / "app.py").read_text())
    stored = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and isinstance(n.ctx, ast.Store)}
    assert not stored & {row.handler for row in keys.KEYS}


def test_help_line_panel_list_and_readme_come_from_the_table():
    line = keys.help_line()
    assert HUD_HELP == line
    words = [f"{row.label} {row.word}" for row in keys.KEYS if row.hud]
    assert line == "  ".join(words) and "Esc" not in line
    assert keys.HELP == [(row.label, row.help) for row in keys.KEYS]
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert keys.sentence() in readme


def test_key_codes_and_characters_come_from_the_names():
    class Keys:
        NUMBER_3, NUMPAD_3, T, W, F1, F12, ESCAPE = 51, 323, 116, 119, 290, 301, 27
    assert keys.key_names(Keys) == {51: "3", 323: "3", 116: "t", 119: "w", 290: "f1", 301: "f12",
                                    27: "escape"}
    assert set(keys.CHAR_KEYS.values()) <= set(keys.KEY_NAMES)
    assert keys.CHAR_KEYS["="] == "+" and keys.CHAR_KEYS["["] == "-"
    assert keys.parse_keys(",".join(keys.KEY_NAMES)) == list(keys.KEY_NAMES)
    with pytest.raises(Exception, match="unknown key"):
        keys.parse_keys("3,nope")


def test_techniques_past_the_ninth_have_a_key_and_the_help_says_so():
    row = keys.ROWS["t"]
    assert row.handler == "key_next_technique" and "past the ninth" in row.help
    assert "T next" in keys.help_line()


def test_the_ui_reads_its_model_not_the_window():
    """app.window.ui imports none of the window's parts that hold state: it draws the
    UIModel it is given."""
    tree = ast.parse((ROOT / "app" / "window" / "ui.py").read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert not imported & {"app", "compose", "recorder"}
    frame = next(n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == "frame")
    assert [a.arg for a in frame.args.args][:2] == ["self", "model"]
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    assert "app" not in names
