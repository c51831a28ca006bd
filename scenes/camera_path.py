"""Camera paths: a fly-through recorded in the window (--record PATH.json), replayed in the
window (--replay PATH.json) and benchmarked along (python -m app.bench --path PATH.json).

The file (JSON, version 1):

    {
      "format": "many-light-lab camera path",
      "version": 1,
      "scene": "city",                  # the scene it was recorded in (informative)
      "size": [960, 540],               # the window's render size then (informative)
      "keys": [                         # one key per recorded frame, in order
        {"t": 0.0,                      # seconds since the recording started (frame timing)
         "position": [x, y, z], "target": [x, y, z], "up": [0, 1, 0],
         "fov_y_deg": 60.0, "near": 0.1, "far": 1000.0},
        ...
      ]
    }

A replay and the benchmark take one key per frame (the frame timing `t` says how fast it
was flown; frame k of a replay is key k, however long a frame takes).  A bad file is
rejected with one line naming the key and the field (a SceneError: exit status 2).  No GL
here, and nothing of app: the window, capture and the bench all read it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import json
import math
from pathlib import Path

from .errors import FieldChecker, SceneError

FORMAT = "many-light-lab camera path"
VERSION = 1


@dataclass
class CameraPath:
    keys: list = field(default_factory=list)      # scenes.model.Camera
    times: list = field(default_factory=list)     # seconds, one per key
    scene: str = ""
    size: tuple[int, int] | None = None

    def __len__(self) -> int:
        return len(self.keys)

    def camera(self, frame: int):
        """The camera of frame `frame` (one key a frame, looping)."""
        return self.keys[frame % len(self.keys)]

    def add(self, cam, t: float) -> None:
        self.keys.append(cam)
        self.times.append(float(t))

    def as_dict(self) -> dict:
        r = lambda v: [round(float(x), 6) for x in v]
        return {"format": FORMAT, "version": VERSION, "scene": self.scene,
                "size": list(self.size) if self.size else None,
                "keys": [{"t": round(float(t), 4), "position": r(c.position), "target": r(c.target),
                          "up": r(c.up), "fov_y_deg": float(c.fov_y_deg), "near": float(c.near),
                          "far": float(c.far)} for c, t in zip(self.keys, self.times)]}

    def save(self, path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        d = self.as_dict()
        keys = d.pop("keys")
        head = json.dumps(d)[:-1]              # one key a line: diffable, still small
        body = ",\n  ".join(json.dumps(k) for k in keys)
        path.write_text(f'{head}, "keys": [\n  {body}\n]}}\n')
        return path


def _check_header(d, source: str) -> None:
    if not isinstance(d, dict):
        raise SceneError(f"{source}: must be a JSON object with 'keys'")
    if d.get("format", FORMAT) != FORMAT:
        raise SceneError(f"{source}: format: expected '{FORMAT}' (got {d.get('format')!r})")
    if d.get("version", VERSION) != VERSION:
        raise SceneError(f"{source}: version: {d.get('version')!r} is not supported (expected {VERSION})")
    known = {"format", "version", "scene", "size", "keys"}
    unknown = sorted(set(d) - known)
    if unknown:
        raise SceneError(f"{source}: unknown field '{unknown[0]}' (known: {', '.join(sorted(known))})")
    keys = d.get("keys")
    if not isinstance(keys, list) or not keys:
        raise SceneError(f"{source}: keys: must be a non-empty list of camera keys")
    size = d.get("size")
    if size is not None and not (isinstance(size, list) and len(size) == 2
                                 and all(isinstance(v, int) and v > 0 for v in size)):
        raise SceneError(f"{source}: size: must be [width, height] in pixels (got {size!r})")


def from_dict(d, source: str = "camera path") -> CameraPath:
    """A CameraPath from the file's JSON object, every field checked; each key's camera by
    the scene loader's own camera check (scenes.loader.check_camera), every field required."""
    from .loader import check_camera
    _check_header(d, source)
    path = CameraPath(scene=str(d.get("scene") or ""),
                      size=tuple(d["size"]) if d.get("size") is not None else None)
    ctx = FieldChecker(source)
    last_t = -math.inf
    for i, k in enumerate(d["keys"]):
        where = f"keys[{i}]"
        k = ctx.obj(k, where)
        t = ctx.num(k.get("t", float(i)), f"{where}.t", lo=0.0, f32=False)
        if t < last_t:
            ctx.fail(f"{where}.t", f"keys must be in time order ({t:g} after {last_t:g})")
        last_t = t
        path.add(check_camera(ctx, {f: v for f, v in k.items() if f != "t"}, where, defaults={}), t)
    return path


def load(path) -> CameraPath:
    """The camera path file at `path` (one-line SceneError when it is not one)."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise SceneError(f"camera path {p}: cannot read it ({exc.strerror or exc})") from None
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SceneError(f"camera path {p}: not JSON ({exc.msg} at line {exc.lineno})") from None
    return from_dict(d, f"camera path {p}")
