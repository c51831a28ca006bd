"""What every scene source shares: the one error type, the size limits of a scene, and the
field checker the file loaders (JSON scenes, glTF scenes) validate with.

Every rejection is a `SceneError` (a ValueError) whose message is one line
`<file>: <field path>: <what is wrong> (got <value>)`, e.g.
`scene.json: lights[3].radius: must be a finite number in (0, 1e+07] (got -1.0)`.

Range checks apply to the values as they are stored (docs/contracts.md "Contract: scene files"): a light's
fields and the geometry live in float32, so `FieldChecker.num` rounds to float32 first and
checks the rounded value; nothing that passes can round into an invalid value (a radius of
1e-46 is 0 in float32 and is refused).  The camera is stored as Python floats (float64), so
its checks run on float64 (`f32=False`).
"""
from __future__ import annotations

import difflib
import math
from pathlib import Path

import numpy as np

MAX_LIGHTS = 4_194_304
MAX_RESOLUTION = 16384
MAX_RADIUS = 1e7
MAX_FAR_NEAR = 1e9
FLOAT32_MAX = float(np.finfo(np.float32).max)


class SceneError(ValueError):
    """A scene that cannot be built or loaded; the message is one line naming file and field."""


# ------------------------------------------------------------------------------ formatting
def one_line(s) -> str:
    return " ".join(str(s).split())


def show(v, limit: int = 60) -> str:
    if isinstance(v, (np.ndarray, np.generic)):
        v = v.tolist()
    s = one_line(repr(v))
    return s if len(s) <= limit else s[:limit - 3] + "..."


def jtype(v) -> str:
    """The JSON name of a parsed value's type."""
    if isinstance(v, bool):
        return "boolean"
    if v is None:
        return "null"
    if isinstance(v, (int, float)):
        return "number"
    if isinstance(v, str):
        return "string"
    if isinstance(v, (list, tuple)):
        return "array"
    if isinstance(v, dict):
        return "object"
    return type(v).__name__


def is_num(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def finite32(x: float) -> bool:
    """Finite and representable as a finite float32."""
    return math.isfinite(x) and abs(x) <= FLOAT32_MAX


def to_f32(x: float) -> float:
    """`x` as float32 stores it (inf past the float32 range)."""
    with np.errstate(over="ignore"):
        return float(np.float32(x))


def closest(key: str, known) -> str | None:
    """The known key nearest to `key` (a case-insensitive match first, then difflib's)."""
    known = list(known)
    for k in known:
        if k.lower() == str(key).lower():
            return k
    best = difflib.get_close_matches(str(key), known, n=1, cutoff=0.0)
    return best[0] if best else None


def suggest(key: str, known) -> str:
    """' (did you mean 'albedo'?)' for a near miss; for a key like no known one, the closest
    and the whole list: ' (closest known key: 'camera'; known keys: resolution, camera)'."""
    known = list(known)
    near = closest(key, known)
    if near is None:
        return ""
    if difflib.SequenceMatcher(None, str(key).lower(), near.lower()).ratio() >= 0.6:
        return f" (did you mean {near!r}?)"
    return f" (closest known key: {near!r}; known keys: {', '.join(known)})"


def _range_text(lo, hi, lo_incl, hi_incl) -> str:
    fmt = lambda x: f"{x:g}"
    if lo is not None and hi is not None:
        return f" in {'[' if lo_incl else '('}{fmt(lo)}, {fmt(hi)}{']' if hi_incl else ')'}"
    if lo is not None:
        return f" {'>=' if lo_incl else '>'} {fmt(lo)}"
    if hi is not None:
        return f" {'<=' if hi_incl else '<'} {fmt(hi)}"
    return ""


def _in_range(x, lo, hi, lo_incl, hi_incl) -> bool:
    if lo is not None and (x < lo or (x == lo and not lo_incl)):
        return False
    if hi is not None and (x > hi or (x == hi and not hi_incl)):
        return False
    return True


# ------------------------------------------------------------------------------ the checker
class FieldChecker:
    """Typed readers that fail with one line `<source>: <field>: <message>`."""

    def __init__(self, source: str, base_dir=None):
        self.source = source
        self.base_dir = Path(base_dir) if base_dir is not None else Path(".")

    def fail(self, field: str, msg: str):
        raise SceneError(f"{self.source}: {field}: {one_line(msg)}")

    def req(self, obj: dict, key: str, field: str):
        if key not in obj:
            self.fail(field, "missing required key")
        return obj[key]

    def obj(self, v, field: str) -> dict:
        if not isinstance(v, dict):
            self.fail(field, f"must be an object (got {jtype(v)})")
        return v

    def arr(self, v, field: str) -> list:
        if not isinstance(v, (list, tuple)):
            self.fail(field, f"must be an array (got {jtype(v)})")
        return list(v)

    def keys(self, obj: dict, field: str, known, what: str = "", elsewhere: dict | None = None) -> None:
        """Every key of `obj` must be in `known`.  `elsewhere` maps keys that are valid for
        another kind of entry to that kind ('direction' -> 'spot lights'); `what` names this
        entry's kind for that message."""
        for k in obj:
            if k in known:
                continue
            if elsewhere and k in elsewhere:
                self.fail(field, f"key {show(k)} does not apply to {what} (only to {elsewhere[k]})")
            self.fail(field, f"unknown key {show(k)}{suggest(k, known)}")

    def num(self, v, field: str, lo=None, hi=None, lo_incl=True, hi_incl=True,
            f32: bool = True) -> float:
        """A finite number in the range, checked on its float32 value when `f32` (the value
        as stored); returns the number as given (float)."""
        want = "must be a finite number" + _range_text(lo, hi, lo_incl, hi_incl)
        if not is_num(v):
            self.fail(field, f"{want} (got {jtype(v)} {show(v)})")
        try:
            x = float(v)
        except OverflowError:
            self.fail(field, f"{want} (got {show(v)})")
        stored = to_f32(x) if f32 else x
        if not finite32(stored) or not _in_range(stored, lo, hi, lo_incl, hi_incl):
            note = f", {stored!r} in float32" if f32 and math.isfinite(x) and stored != x else ""
            self.fail(field, f"{want} (got {show(v)}{note})")
        return x

    def vec3(self, v, field: str, lo=None, f32: bool = True) -> tuple[float, float, float]:
        want = "must be an array of 3 finite numbers" + ("" if lo is None else f" >= {lo:g}")
        if not isinstance(v, (list, tuple)) or len(v) != 3:
            self.fail(field, f"{want} (got {jtype(v)} {show(v)})")
        return tuple(self.num(x, f"{field}[{i}]", lo=lo, f32=f32) for i, x in enumerate(v))

    def direction(self, v, field: str, f32: bool = True) -> np.ndarray:
        """A non-zero finite 3-vector, returned normalised (float64)."""
        d = np.array(self.vec3(v, field, f32=f32), np.float64)
        m = np.abs(d).max()
        if not m > 0:
            self.fail(field, f"must be a non-zero finite vector (got {show(list(v))})")
        d = d / m
        return d / np.linalg.norm(d)

    def path(self, v, field: str) -> tuple[str, Path]:
        if not isinstance(v, str) or not v:
            self.fail(field, f"must be a non-empty string path (got {jtype(v)} {show(v)})")
        p = self.base_dir / v
        if not p.is_file():
            self.fail(field, f"cannot read {v!r}: file not found")
        return v, p
