"""The window's keys, declared once in one table (KEYS): each row is an action, the key names
it answers to, the word the HUD's help line gives it, the panel's description and the
window's handler.  From the table come:

    KEY_NAMES    every key name (what the handler and --keys speak)
    key_names    {window key code: key name} for a moderngl-window Keys class
    CHAR_KEYS    {typed character: key name} (+, -, [ and ] arrive as characters:
                 keyboard layouts do not matter)
    help_line    the HUD's help line
    HELP         the panel's key list
    sentence     the README's key list (a test holds the README to it)
    dispatch     a key press run on the window: its row's handler, called with the key name

A --keys entry is one step per frame: a key name ("3", "v", "f12"), a panel change
("tile=32": app.window.panel, applied as the widget would be, so the next frame renders with
it), or a click on a panel widget by its key ("click:duplicated": imgui mouse events at the
widget's place, as a user's click).
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Key:
    names: tuple[str, ...]       # key names (the first is the one shown when label is empty)
    label: str                   # as the help shows the key: "1-9", "K/F12"
    word: str                    # the HUD help line's word
    help: str                    # the panel's description
    handler: str                 # the window's method, called with the key name
    held: bool = False           # held down (flying): the window moves while it is down
    chars: dict = field(default_factory=dict)     # typed characters that mean one of the names
    hud: bool = True             # on the HUD's help line (Esc is not: it is in the panel's list)


# W/A/S/D/Q/E: (forward, right, up) axes of the fly camera.
MOVE_KEYS = {"w": (1, 0, 0), "s": (-1, 0, 0), "d": (0, 1, 0), "a": (0, -1, 0),
             "e": (0, 0, 1), "q": (0, 0, -1)}

KEYS = (
    Key(tuple("123456789"), "1-9", "technique", "technique (the first nine, registry order)",
        "key_technique"),
    Key(("t",), "T", "next", "next technique: every one, past the ninth too (and the panel's "
        "technique list)", "key_next_technique"),
    Key(("v",), "V", "view", "next view of this technique", "key_view"),
    Key(("o",), "O", "overlay", "heat map over the shaded image", "key_overlay"),
    Key(("i",), "I", "inspect", "inspect the cursor", "key_inspect"),
    Key(("m",), "M", "map", "next map of the technique's own structure", "key_next_map"),
    Key(tuple(MOVE_KEYS), "WASD/QE+drag", "fly", "fly (Shift faster, wheel: speed; drag: look)",
        "key_fly", held=True),
    Key(("b",), "B", "stereo", "mono / stereo: both eyes side by side", "key_stereo"),
    Key((">", "<"), "</>", "slice", "next / previous froxel slice (froxels view, fog scenes)",
        "key_froxel_slice", chars={">": ">", ".": ">", "<": "<", ",": "<"}),
    Key(("p",), "P", "path", "play / stop the camera path", "key_play"),
    Key(("c",), "C", "record", "record a camera path / stop and save", "key_record"),
    Key(("r",), "R", "reset", "reset the camera", "key_reset"),
    Key(("+", "-", "]", "["), "+/-", "lights", "double / halve the lights", "key_lights",
        chars={"+": "+", "=": "+", "]": "+", "-": "-", "_": "-", "[": "-"}),
    Key(("k", "f12"), "K/F12", "shot", "screenshot", "key_screenshot"),
    Key(("h",), "H", "hide", "hide the HUD and panel", "key_hide"),
    Key(("f1",), "F1", "panel", "hide the panel", "key_panel"),
    Key(("escape",), "Esc", "quit", "quit", "key_quit", hud=False),
)
ROWS = {name: row for row in KEYS for name in row.names}
KEY_NAMES = tuple(ROWS)
CHAR_KEYS = {c: name for row in KEYS for c, name in row.chars.items()}
HELP = [(row.label, row.help) for row in KEYS]


def help_line() -> str:
    """The HUD's help line: "1-9 technique  T next  V view ..."."""
    return "  ".join(f"{row.label} {row.word}" for row in KEYS if row.hud)


def sentence() -> str:
    """The README's key list: "1-9 technique, T next, ..., Esc quit"."""
    return ", ".join(f"{row.label} {row.word}" for row in KEYS)


def dispatch(target, name: str) -> None:
    """Run key `name` on `target` (the window): its row's handler, given the key name."""
    getattr(target, ROWS[name].handler)(name)


def _codes(name: str) -> tuple[str, ...]:
    """The moderngl-window Keys attributes of a key name (none: it arrives as a character)."""
    if name.isdigit():
        return (f"NUMBER_{name}", f"NUMPAD_{name}")
    if name == "escape":
        return ("ESCAPE",)
    if name.isalnum():
        return (name.upper(),)
    return ()


def key_names(keys) -> dict:
    """{window key code: key name} for a moderngl-window Keys class (codes a window type
    lacks, None or "undefined", are left out)."""
    pairs = [(getattr(keys, attr, None), name) for name in KEY_NAMES for attr in _codes(name)]
    return {code: name for code, name in pairs if code not in (None, "undefined")}


def _panel_step(kind: str, name: str, value: str, panel_keys, bad: list) -> str:
    name = name.strip().lower().replace("-", "_")
    if panel_keys is not None and name not in panel_keys:
        bad.append(f"{name}={value}" if kind == "=" else f"click:{name}")
    return f"{name}={value.strip()}" if kind == "=" else f"click:{name}"


def parse_keys(text: str, panel_keys=None) -> list[str]:
    """--keys "3, v,tile=32,click:duplicated" -> ["3", "v", "tile=32", "click:duplicated"];
    an unknown key name or panel key is an argument error."""
    out, bad = [], []
    for k in (k.strip() for k in text.split(",")):
        if not k:
            continue
        if "=" in k:
            name, _, value = k.partition("=")
            out.append(_panel_step("=", name, value, panel_keys, bad))
        elif k.lower().startswith("click:"):
            out.append(_panel_step("click", k.split(":", 1)[1], "", panel_keys, bad))
        elif k.lower() in ROWS:
            out.append(k.lower())
        else:
            bad.append(k)
    if bad:
        raise argparse.ArgumentTypeError(
            f"unknown key(s) {', '.join(bad)} (keys: {' '.join(KEY_NAMES)}; panel: NAME=VALUE "
            f"or click:NAME with a panel control's name)")
    return out
