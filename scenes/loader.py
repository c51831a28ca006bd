"""Scene loading: builtin names and JSON scene files (DESIGN.md "Contract: scene files").

Every rejection is a `SceneError` (a ValueError) whose message is one line
`<file>: <field path>: <what is wrong> (got <value>)`, e.g.
`scene.json: lights[3].radius: must be a finite number in (0, 1e+07] (got -1.0)`.
Unknown keys are ignored; unknown light types are not.
"""
from __future__ import annotations

import json
import math
import zipfile
from pathlib import Path

import numpy as np

from .builtin import BUILTIN_SCENES
from .errors import MAX_LIGHTS, SceneError
from .geometry import box_mesh, max_depth_for
from .model import LIGHT_DTYPE, LIGHT_SPOT, LIGHT_TYPES as TYPE_NAMES, Camera, Mesh, Scene, make_lights

MAX_RESOLUTION = 16384
MAX_RADIUS = 1e7
MAX_FAR_NEAR = 1e9
FLOAT32_MAX = float(np.finfo(np.float32).max)
NPZ_ARRAYS = ("type", "position", "radius", "color", "intensity", "direction",
              "cos_inner", "cos_outer")
LIGHT_TYPES = {name: i for i, name in enumerate(TYPE_NAMES)}
DEFAULT_ALBEDO = (0.8, 0.8, 0.8)


def _one_line(s) -> str:
    return " ".join(str(s).split())


def _show(v, limit: int = 60) -> str:
    if isinstance(v, (np.ndarray, np.generic)):
        v = v.tolist()
    s = _one_line(repr(v))
    return s if len(s) <= limit else s[:limit - 3] + "..."


def _jtype(v) -> str:
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


def _is_num(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _finite(x: float) -> bool:
    return math.isfinite(x) and abs(x) <= FLOAT32_MAX


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


class _Ctx:
    def __init__(self, source: str, base_dir):
        self.source = source
        self.base_dir = Path(base_dir) if base_dir is not None else Path(".")

    def fail(self, field: str, msg: str):
        raise SceneError(f"{self.source}: {field}: {_one_line(msg)}")

    # ---- typed readers --------------------------------------------------------------
    def req(self, obj: dict, key: str, field: str):
        if key not in obj:
            self.fail(field, "missing required key")
        return obj[key]

    def obj(self, v, field: str) -> dict:
        if not isinstance(v, dict):
            self.fail(field, f"must be an object (got {_jtype(v)})")
        return v

    def arr(self, v, field: str) -> list:
        if not isinstance(v, (list, tuple)):
            self.fail(field, f"must be an array (got {_jtype(v)})")
        return list(v)

    def num(self, v, field: str, lo=None, hi=None, lo_incl=True, hi_incl=True) -> float:
        want = "must be a finite number" + _range_text(lo, hi, lo_incl, hi_incl)
        if not _is_num(v):
            self.fail(field, f"{want} (got {_jtype(v)} {_show(v)})")
        x = float(v)
        if not _finite(x) or not _in_range(x, lo, hi, lo_incl, hi_incl):
            self.fail(field, f"{want} (got {_show(v)})")
        return x

    def vec3(self, v, field: str, lo=None) -> tuple[float, float, float]:
        want = "must be an array of 3 finite numbers" + ("" if lo is None else f" >= {lo:g}")
        if not isinstance(v, (list, tuple)) or len(v) != 3:
            self.fail(field, f"{want} (got {_jtype(v)} {_show(v)})")
        return tuple(self.num(x, f"{field}[{i}]", lo=lo) for i, x in enumerate(v))

    def direction(self, v, field: str) -> np.ndarray:
        d = np.array(self.vec3(v, field), np.float64)
        m = np.abs(d).max()
        if not m > 0:
            self.fail(field, f"must be a non-zero finite vector (got {_show(list(v))})")
        d = d / m
        return d / np.linalg.norm(d)

    def path(self, v, field: str) -> tuple[str, Path]:
        if not isinstance(v, str) or not v:
            self.fail(field, f"must be a non-empty string path (got {_jtype(v)} {_show(v)})")
        p = self.base_dir / v
        if not p.is_file():
            self.fail(field, f"cannot read {v!r}: file not found")
        return v, p


def _check_finite_tree(ctx: _Ctx, v, field: str) -> None:
    """Reject NaN/Infinity anywhere (Python's json accepts those literals)."""
    if isinstance(v, float) and not _finite(v):
        ctx.fail(field or "top level", f"must be a finite number (got {_show(v)})")
    if isinstance(v, dict):
        for k, x in v.items():
            _check_finite_tree(ctx, x, f"{field}.{k}" if field else str(k))
    elif isinstance(v, (list, tuple)):
        for i, x in enumerate(v):
            _check_finite_tree(ctx, x, f"{field}[{i}]")


# ----------------------------------------------------------------------------- sections
def _resolution(ctx: _Ctx, v) -> tuple[int, int]:
    want = f"must be two integers in 1..{MAX_RESOLUTION}"
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        ctx.fail("resolution", f"{want} (got {_jtype(v)} {_show(v)})")
    out = []
    for i, x in enumerate(v):
        if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)) \
                or not 1 <= int(x) <= MAX_RESOLUTION:
            ctx.fail(f"resolution[{i}]", f"{want} (got {_show(x)})")
        out.append(int(x))
    return out[0], out[1]


def _camera(ctx: _Ctx, v) -> Camera:
    c = ctx.obj(v, "camera")
    pos = ctx.vec3(ctx.req(c, "position", "camera.position"), "camera.position")
    tgt = ctx.vec3(ctx.req(c, "target", "camera.target"), "camera.target")
    up = ctx.direction(c.get("up", [0.0, 1.0, 0.0]), "camera.up")
    fov = ctx.num(c.get("fov_y_deg", 60.0), "camera.fov_y_deg", 0.0, 180.0, False, False)
    near = ctx.num(c.get("near", 0.1), "camera.near", lo=0.0, lo_incl=False)
    far = ctx.num(c.get("far", 1000.0), "camera.far", lo=0.0, lo_incl=False)
    if not far > near:
        ctx.fail("camera.far", f"must be > camera.near (got far {_show(c.get('far'))}, "
                               f"near {_show(c.get('near'))})")
    if far / near > MAX_FAR_NEAR:
        ctx.fail("camera.far", f"far/near must be <= {MAX_FAR_NEAR:g} (got {far / near:g})")
    view = np.subtract(tgt, pos)
    if not np.abs(view).max() > 0:
        ctx.fail("camera.target", f"must differ from camera.position (got {_show(list(tgt))})")
    view = view / np.abs(view).max()
    view /= np.linalg.norm(view)
    if np.linalg.norm(np.cross(view, up)) < 1e-6:
        ctx.fail("camera.up", f"must not be parallel to the view direction (got {_show(c.get('up'))})")
    up_raw = tuple(float(x) for x in c.get("up", [0.0, 1.0, 0.0]))
    return Camera(pos, tgt, up_raw, fov, near, far)


def _albedo(ctx: _Ctx, g: dict, field: str):
    if "albedo" not in g:
        return DEFAULT_ALBEDO
    a = ctx.vec3(g["albedo"], field + ".albedo", lo=0.0)
    for i, x in enumerate(a):
        if x > 1.0:
            ctx.fail(f"{field}.albedo[{i}]", f"must be a finite number in [0, 1] (got {_show(x)})")
    return a


def _matrix4(ctx: _Ctx, v, field: str) -> np.ndarray:
    want = "must be a 4x4 array of finite numbers (row-major)"
    if not isinstance(v, (list, tuple)) or len(v) != 4 or \
            not all(isinstance(r, (list, tuple)) and len(r) == 4 for r in v):
        ctx.fail(field, f"{want} (got {_show(v)})")
    m = np.array([[ctx.num(x, f"{field}[{i}][{j}]") for j, x in enumerate(r)]
                  for i, r in enumerate(v)], np.float64)
    if not np.allclose(m[3], (0, 0, 0, 1), rtol=0, atol=1e-9):
        ctx.fail(f"{field}[3]", f"must be [0, 0, 0, 1]: affine, translation in the last column "
                                f"(got {_show(m[3])})")
    return m


def _load_mesh(ctx: _Ctx, g: dict, field: str) -> Mesh:
    rel, path = ctx.path(g["mesh"], field + ".mesh")
    m = _matrix4(ctx, g["transform"], field + ".transform") if "transform" in g else np.eye(4)
    albedo = _albedo(ctx, g, field)
    try:
        import trimesh
        tm = trimesh.load(str(path), force="mesh", process=False)
    except Exception as e:  # noqa: BLE001 - any reader failure is a bad file
        ctx.fail(field + ".mesh", f"cannot read {rel!r}: {type(e).__name__}: {e}")
    faces = getattr(tm, "faces", None)
    verts = getattr(tm, "vertices", None)
    if faces is None or verts is None or len(faces) == 0:
        ctx.fail(field + ".mesh", f"mesh {rel!r} has no faces")
    verts = np.asarray(verts, np.float64)
    faces = np.asarray(faces)
    if not np.all(np.isfinite(verts)):
        ctx.fail(field + ".mesh", f"mesh {rel!r} has non-finite vertices")
    if faces.ndim != 2 or faces.shape[1] != 3 or faces.min() < 0 or faces.max() >= len(verts):
        ctx.fail(field + ".mesh", f"mesh {rel!r} has invalid faces")
    v = verts @ m[:3, :3].T + m[:3, 3]
    if not np.all(np.abs(v) <= FLOAT32_MAX):
        ctx.fail(field + ".transform", "transformed vertices overflow float32")
    return Mesh(v.astype(np.float32), faces.astype(np.int32), albedo)


def _geometry(ctx: _Ctx, v) -> list[Mesh]:
    meshes = []
    for i, g in enumerate(ctx.arr(v, "geometry")):
        f = f"geometry[{i}]"
        ctx.obj(g, f)
        kinds = [k for k in ("box", "mesh") if k in g]
        if len(kinds) != 1:
            ctx.fail(f, f"must have exactly one of 'box' or 'mesh' (got keys {_show(sorted(g))})")
        if kinds[0] == "box":
            b = ctx.obj(g["box"], f + ".box")
            lo = ctx.vec3(ctx.req(b, "min", f + ".box.min"), f + ".box.min")
            hi = ctx.vec3(ctx.req(b, "max", f + ".box.max"), f + ".box.max")
            for a in range(3):
                if lo[a] > hi[a]:
                    ctx.fail(f + ".box.min", f"must be <= box.max on every axis "
                                             f"(got min {_show(list(lo))} max {_show(list(hi))})")
            meshes.append(box_mesh(lo, hi, _albedo(ctx, g, f)))
        else:
            meshes.append(_load_mesh(ctx, g, f))
    return meshes


def _json_lights(ctx: _Ctx, v) -> np.ndarray:
    items = ctx.arr(v, "lights")
    if len(items) > MAX_LIGHTS:
        ctx.fail("lights", f"at most {MAX_LIGHTS} lights (got {len(items)})")
    out = make_lights(len(items))
    for i, L in enumerate(items):
        f = f"lights[{i}]"
        ctx.obj(L, f)
        t = ctx.req(L, "type", f + ".type")
        if not isinstance(t, str) or t not in LIGHT_TYPES:
            ctx.fail(f + ".type", f"unknown light type {_show(t)} (expected one of: "
                                  f"{', '.join(LIGHT_TYPES)})")
        rec = out[i]
        rec["type"] = LIGHT_TYPES[t]
        rec["position"] = ctx.vec3(ctx.req(L, "position", f + ".position"), f + ".position")
        rec["radius"] = ctx.num(ctx.req(L, "radius", f + ".radius"), f + ".radius",
                                0.0, MAX_RADIUS, lo_incl=False)
        if "color" in L:
            rec["color"] = ctx.vec3(L["color"], f + ".color", lo=0.0)
        if "intensity" in L:
            rec["intensity"] = ctx.num(L["intensity"], f + ".intensity", lo=0.0)
        if t == "spot":
            rec["direction"] = ctx.direction(ctx.req(L, "direction", f + ".direction"),
                                             f + ".direction")
            inner = ctx.num(ctx.req(L, "inner_angle_deg", f + ".inner_angle_deg"),
                            f + ".inner_angle_deg", 0.0, 90.0, False, False)
            outer = ctx.num(ctx.req(L, "outer_angle_deg", f + ".outer_angle_deg"),
                            f + ".outer_angle_deg", 0.0, 90.0, False, False)
            if inner > outer:
                ctx.fail(f + ".inner_angle_deg", f"must be <= outer_angle_deg "
                                                 f"(got {inner:g} > {outer:g})")
            rec["cos_inner"] = math.cos(math.radians(inner))
            rec["cos_outer"] = math.cos(math.radians(outer))
    return out


def _npz_lights(ctx: _Ctx, v, n_json: int) -> np.ndarray:
    rel, path = ctx.path(v, "lights_npz")
    if not zipfile.is_zipfile(path):
        ctx.fail("lights_npz", f"cannot read {rel!r}: not an .npz (zip) archive")
    try:
        z = np.load(str(path), allow_pickle=False)
    except Exception as e:  # noqa: BLE001
        ctx.fail("lights_npz", f"cannot read {rel!r}: {type(e).__name__}: {e}")
    if not isinstance(z, np.lib.npyio.NpzFile):
        ctx.fail("lights_npz", f"cannot read {rel!r}: not an .npz archive")
    with z:
        for key in NPZ_ARRAYS:
            if key not in z.files:
                ctx.fail(f"lights_npz.{key}", f"missing array in {rel!r}")
        arrays = {}
        for key in NPZ_ARRAYS:
            f = f"lights_npz.{key}"
            try:
                a = z[key]
            except Exception as e:  # noqa: BLE001
                ctx.fail(f, f"cannot read from {rel!r}: {type(e).__name__}: {e}")
            if a.dtype.kind not in ("iu" if key == "type" else "iuf"):
                ctx.fail(f, f"must be a{'n integer' if key == 'type' else ' numeric'} array "
                            f"(got dtype {a.dtype})")
            if key == "type":
                if a.ndim != 1:
                    ctx.fail(f, f"must have shape (N,) (got {a.shape})")
                if n_json + len(a) > MAX_LIGHTS:
                    ctx.fail("lights_npz", f"total light count must be <= {MAX_LIGHTS} "
                                           f"(got {n_json + len(a)})")
                n = len(a)
            want = (n, 3) if key in ("position", "color", "direction") else (n,)
            if a.shape != want:
                ctx.fail(f, f"must have shape {want} to match lights_npz.type (got {a.shape})")
            arrays[key] = a
    t = arrays["type"]
    f64 = {k: arrays[k].astype(np.float64) for k in NPZ_ARRAYS if k != "type"}

    def first_bad(key, bad):
        bad = bad if bad.ndim == 1 else bad.any(axis=1)
        idx = np.flatnonzero(bad)
        return int(idx[0]) if len(idx) else None

    def check(key, bad, want):
        i = first_bad(key, bad)
        if i is not None:
            ctx.fail(f"lights_npz.{key}[{i}]", f"{want} (got {_show(arrays[key][i])})")

    check("type", ~np.isin(t, list(LIGHT_TYPES.values())),
          "must be a light type id: 0 (point) or 1 (spot)")
    for key, a in f64.items():
        check(key, ~(np.isfinite(a) & (np.abs(a) <= FLOAT32_MAX)), "must be finite")
    check("radius", ~((f64["radius"] > 0) & (f64["radius"] <= MAX_RADIUS)),
          "must be a finite number in (0, 1e+07]")
    check("color", f64["color"] < 0, "must be >= 0")
    check("intensity", f64["intensity"] < 0, "must be >= 0")
    spot = t == LIGHT_SPOT
    d = f64["direction"]
    m = np.abs(d).max(axis=1)
    check("direction", spot & ~(m > 0), "a spot light's direction must be a non-zero vector")
    for key in ("cos_inner", "cos_outer"):
        c = f64[key]
        check(key, spot & ~((c > 0) & (c < 1)),
              "a spot light's cosine must be in (0, 1) (angle in (0, 90) degrees)")
    check("cos_inner", spot & (f64["cos_inner"] < f64["cos_outer"]),
          "must be >= cos_outer (inner angle <= outer angle)")
    out = np.zeros(len(t), LIGHT_DTYPE)
    out["type"] = t
    for key in ("position", "radius", "color", "intensity", "cos_inner", "cos_outer"):
        out[key] = f64[key]
    dn = d.copy()
    if spot.any():
        ds = d[spot] / m[spot, None]
        dn[spot] = ds / np.linalg.norm(ds, axis=1, keepdims=True)
    out["direction"] = dn
    return out


# -------------------------------------------------------------------------------- API
def scene_from_dict(d, base_dir=None, source_name: str = "<scene>") -> Scene:
    """Validate a parsed JSON scene (DESIGN.md contract) and build the Scene.

    `base_dir` resolves relative mesh / npz paths; `source_name` prefixes every error."""
    ctx = _Ctx(str(source_name), base_dir)
    if not isinstance(d, dict):
        ctx.fail("top level", f"must be a JSON object (got {_jtype(d)})")
    _check_finite_tree(ctx, d, "")
    resolution = _resolution(ctx, ctx.req(d, "resolution", "resolution"))
    camera = _camera(ctx, ctx.req(d, "camera", "camera"))
    meshes = _geometry(ctx, d.get("geometry", []))
    lights = _json_lights(ctx, ctx.req(d, "lights", "lights"))
    if "lights_npz" in d:
        lights = np.concatenate([lights, _npz_lights(ctx, d["lights_npz"], len(lights))])
    name = Path(str(source_name)).stem or str(source_name)
    return Scene(name=name, resolution=resolution, camera=camera, meshes=meshes, lights=lights,
                 path=[], max_depth=max_depth_for([camera], meshes))


def load_scene(name_or_path: str, lights: int | None = None, seed: int = 0,
               distribution: str | None = None) -> Scene:
    """A builtin scene by name, or a JSON scene file.  For a file, `lights=N` keeps the first
    N lights and `seed` / `distribution` are ignored."""
    src = str(name_or_path)
    if src in BUILTIN_SCENES:
        return BUILTIN_SCENES[src](lights, seed, distribution)
    path = Path(src)
    if not path.is_file():
        raise SceneError(f"{src}: not a builtin scene ({', '.join(BUILTIN_SCENES)}) "
                         f"and no such file")
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except (OSError, UnicodeDecodeError) as e:
        raise SceneError(f"{src}: cannot read: {_one_line(e)}") from None
    try:
        d = json.loads(text)
    except json.JSONDecodeError as e:
        raise SceneError(f"{src}: line {e.lineno} col {e.colno}: invalid JSON: "
                         f"{_one_line(e.msg)}") from None
    except RecursionError:
        raise SceneError(f"{src}: top level: invalid JSON: nested too deeply") from None
    scene = scene_from_dict(d, path.parent, src)
    if lights is not None:
        n = len(scene.lights)
        if isinstance(lights, bool) or not isinstance(lights, (int, np.integer)) \
                or not 0 <= lights <= n:
            raise SceneError(f"{src}: lights: --lights must be an integer in 0..{n}, "
                             f"the scene's light count (got {lights!r})")
        scene.lights = scene.lights[:int(lights)].copy()
    return scene
