"""Key names: what a key press means, whatever the window type.  The handler and --keys
(scripted runs) speak the same names; `key_names` maps a window's key codes onto them."""
from __future__ import annotations

import argparse

# W/A/S/D/Q/E: (forward, right, up) axes of the fly camera.
MOVE_KEYS = {"w": (1, 0, 0), "s": (-1, 0, 0), "d": (0, 1, 0), "a": (0, -1, 0),
             "e": (0, 0, 1), "q": (0, 0, -1)}
KEY_NAMES = tuple("123456789") + tuple(MOVE_KEYS) + ("v", "p", "r", "h", "k", "f12", "+", "-",
                                                     "]", "[", "escape")
# +, -, [ and ] arrive as characters (on_unicode_char_entered): keyboard layouts do not matter.
CHAR_KEYS = {"+": "+", "=": "+", "-": "-", "_": "-", "]": "+", "[": "-"}


def parse_keys(text: str) -> list[str]:
    """--keys "3, v,f12" -> ["3", "v", "f12"]; an unknown name is an argument error."""
    keys = [k.strip().lower() for k in text.split(",") if k.strip()]
    bad = [k for k in keys if k not in KEY_NAMES]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown key(s) {', '.join(bad)} (known: {' '.join(KEY_NAMES)})")
    return keys


def key_names(keys) -> dict:
    """{window key code: key name} for a moderngl-window Keys class (codes a window type
    lacks, None or "undefined", are left out)."""
    pairs = [(getattr(keys, f"NUMBER_{i}", None), str(i)) for i in range(1, 10)]
    pairs += [(getattr(keys, f"NUMPAD_{i}", None), str(i)) for i in range(1, 10)]
    pairs += [(getattr(keys, c.upper(), None), c) for c in "wasdqevprhk"]
    pairs += [(getattr(keys, "F12", None), "f12"), (getattr(keys, "ESCAPE", None), "escape")]
    return {code: name for code, name in pairs if code not in (None, "undefined")}
