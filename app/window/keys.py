"""Key names: what a key press means, whatever the window type.  The handler and --keys
(scripted runs) speak the same names; `key_names` maps a window's key codes onto them.

A --keys entry is one step per frame: a key name ("3", "v", "f12"), a panel change
("tile=32": app.window.panel, applied as the widget would be, so the next frame renders with
it), or a click on a panel widget by its key ("click:duplicated": imgui mouse events at the
widget's place, as a user's click).
"""
from __future__ import annotations

import argparse

# W/A/S/D/Q/E: (forward, right, up) axes of the fly camera.
MOVE_KEYS = {"w": (1, 0, 0), "s": (-1, 0, 0), "d": (0, 1, 0), "a": (0, -1, 0),
             "e": (0, 0, 1), "q": (0, 0, -1)}
KEY_NAMES = tuple("123456789") + tuple(MOVE_KEYS) + ("v", "o", "i", "m", "p", "c", "r", "h", "k", "f1",
                                                     "f12", "+", "-", "]", "[", "escape")
# +, -, [ and ] arrive as characters (on_unicode_char_entered): keyboard layouts do not matter.
CHAR_KEYS = {"+": "+", "=": "+", "-": "-", "_": "-", "]": "+", "[": "-"}

# (keys, the HUD's word, the panel's description): the HUD line and the panel's key list
# both come from here.
KEYS = [
    ("1-9", "technique", "technique (registry order)"), ("V", "view", "next view of this technique"),
    ("O", "overlay", "heat map over the shaded image"), ("I", "inspect", "inspect the cursor"),
    ("M", "map", "next map of the technique's own structure"),
    ("WASD/QE+drag", "fly", "fly (Shift faster, wheel: speed; drag: look)"),
    ("P", "path", "play / stop the camera path"), ("C", "record", "record a camera path / stop and save"),
    ("R", "reset", "reset the camera"), ("+/-", "lights", "double / halve the lights"),
    ("K", "shot", "screenshot (also F12)"), ("H", "hide", "hide the HUD and panel"),
    ("F1", "panel", "hide the panel"), ("Esc", "quit", "quit"),
]
HELP = [(k, long) for k, _, long in KEYS]


def parse_keys(text: str, panel_keys=None) -> list[str]:
    """--keys "3, v,tile=32,click:duplicated" -> ["3", "v", "tile=32", "click:duplicated"];
    an unknown key name or panel key is an argument error."""
    steps = [k.strip() for k in text.split(",") if k.strip()]
    out, bad = [], []
    for k in steps:
        if "=" in k:
            name, _, value = k.partition("=")
            name = name.strip().lower().replace("-", "_")
            if panel_keys is not None and name not in panel_keys:
                bad.append(k)
            out.append(f"{name}={value.strip()}")
        elif k.lower().startswith("click:"):
            name = k.split(":", 1)[1].strip().lower().replace("-", "_")
            if panel_keys is not None and name not in panel_keys:
                bad.append(k)
            out.append(f"click:{name}")
        elif k.lower() in KEY_NAMES:
            out.append(k.lower())
        else:
            bad.append(k)
    if bad:
        raise argparse.ArgumentTypeError(
            f"unknown key(s) {', '.join(bad)} (keys: {' '.join(KEY_NAMES)}; panel: NAME=VALUE "
            f"or click:NAME with a panel control's name)")
    return out


def key_names(keys) -> dict:
    """{window key code: key name} for a moderngl-window Keys class (codes a window type
    lacks, None or "undefined", are left out)."""
    pairs = [(getattr(keys, f"NUMBER_{i}", None), str(i)) for i in range(1, 10)]
    pairs += [(getattr(keys, f"NUMPAD_{i}", None), str(i)) for i in range(1, 10)]
    pairs += [(getattr(keys, c.upper(), None), c) for c in "wasdqevoimprchk"]
    pairs += [(getattr(keys, "F1", None), "f1"), (getattr(keys, "F12", None), "f12"),
              (getattr(keys, "ESCAPE", None), "escape")]
    return {code: name for code, name in pairs if code not in (None, "undefined")}
