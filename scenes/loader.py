"""Scene loading: builtin names, JSON scene files and glTF 2.0 files (docs/contracts.md "Contract:
scene files"; glTF in scenes/gltf.py).

Every rejection is a `SceneError` (a ValueError) whose message is one line
`<file>: <field path>: <what is wrong> (got <value>)`, e.g.
`scene.json: lights[3].radius: must be a finite number in (0, 1e+07] (got -1.0)`.

Strict on purpose:
- an unknown key is an error at every level (top, camera, geometry entries, box, lights, the
  arrays of `lights_npz`), naming the key and the closest known one:
  `geometry[0]: unknown key 'albdo' (did you mean 'albedo'?)`; a key of another kind of entry
  says so (`lights[0]: key 'direction' does not apply to a point light (only to spot, capsule
  and box lights)`);
- range checks apply to the values as stored: lights and geometry are float32, so a value is
  rounded to float32 before its range is checked (errors.FieldChecker.num); the camera is
  stored as float64 and checked as such;
- spot angles follow glTF (KHR_lights_punctual): 0 <= inner <= outer, 0 < outer <= 90
  degrees, and the stored cos(outer) must stay below 1 in float32 (a cone too narrow to hold
  anything is refused rather than rounded into an empty one);
- the builtin scenes' draw arguments (`distribution`, a non-default `seed`) are errors for a
  file (load_scene).

Light shapes (docs/contracts.md "Light model"): point, spot, capsule (`direction`, `length` >= 0) and box
(`direction`, `up` not parallel to it, half extents `extent` > 0, no `radius`: a box light's
stored radius is its bounding sphere |extent|, the model ignores it).
"""
from __future__ import annotations

import json
import math
import zipfile
from pathlib import Path

import numpy as np

from .builtin import BUILTIN_SCENES, BUILTIN_VARIANTS
from .errors import (FLOAT32_MAX, MAX_FAR_NEAR, MAX_LIGHTS, MAX_RADIUS, MAX_RESOLUTION,
                     FieldChecker, SceneError, jtype, one_line, show, suggest, to_f32)
from .geometry import box_mesh, max_depth_for
from .gltf import GLTF_SUFFIXES, load_gltf
from .motion import KINDS as MOTION_KINDS, MAX_SPEED, Motion, outside as motion_outside
from .model import (LIGHT_BOX, LIGHT_CAPSULE, LIGHT_DTYPE, LIGHT_SPOT, LIGHT_TYPES as TYPE_NAMES,
                    Camera, Fog, Mesh, Scene, make_lights)

__all__ = ["load_scene", "scene_from_dict", "check_camera", "SceneError", "MAX_LIGHTS"]

NPZ_ARRAYS = ("type", "position", "radius", "color", "intensity", "direction",
              "cos_inner", "cos_outer")
NPZ_SHAPE_ARRAYS = ("length", "up", "extent")    # optional (absent: zeros): capsules, boxes
NPZ_VEC3 = ("position", "color", "direction", "up", "extent")
DEFAULT_ALBEDO = (0.8, 0.8, 0.8)

# The keys of each object of the contract, by kind where the kind decides.
TOP_KEYS = ("resolution", "camera", "geometry", "lights", "lights_npz", "motion", "fog")
FOG_KEYS = ("density", "albedo", "far", "anisotropy")
MAX_FOG_DENSITY = 1e3      # extinction per metre: beyond, a metre of fog is opaque to 1e-434
MOTION_KEYS = ("kind", "speed", "seed", "bounds")
CAMERA_KEYS = ("position", "target", "up", "fov_y_deg", "near", "far")
BOX_KEYS = ("min", "max")
# A geometry entry's material (docs/contracts.md "Contract: scene files"): albedo, and GGX specular when
# `roughness` is given (> 0; without it, or at 0, the surface is matte), `metallic` in [0, 1].
MATERIAL_KEYS = ("albedo", "roughness", "metallic", "opacity")
GEOMETRY_KEYS = {"box": ("box",) + MATERIAL_KEYS,
                 "mesh": ("mesh", "transform") + MATERIAL_KEYS}
_COMMON = ("type", "position", "color", "intensity")
LIGHT_KEYS = {"point": _COMMON + ("radius",),
              "spot": _COMMON + ("radius", "direction", "inner_angle_deg", "outer_angle_deg"),
              "capsule": _COMMON + ("radius", "direction", "length"),
              "box": _COMMON + ("direction", "up", "extent")}   # a box's bound is the box
# The light types this loader reads: those of the model (type id = index) it has keys for.
LIGHT_TYPES = {name: i for i, name in enumerate(TYPE_NAMES) if name in LIGHT_KEYS}


def _union(by_kind: dict) -> tuple[str, ...]:
    return tuple(dict.fromkeys(k for keys in by_kind.values() for k in keys))


def _elsewhere(by_kind: dict, plural: str) -> dict[str, str]:
    """key -> 'spot, capsule and box lights' / 'mesh entries': where a key belongs."""
    out = {}
    for key in _union(by_kind):
        kinds = [k for k, keys in by_kind.items() if key in keys]
        names = ", ".join(kinds[:-1]) + " and " + kinds[-1] if len(kinds) > 1 else kinds[0]
        out[key] = f"{names} {plural}"
    return out


def cos_deg(angle_deg: float) -> float:
    """cos of an angle in degrees, exact at 0 and 90 (a 90-degree cone stores cos_outer 0)."""
    return 0.0 if angle_deg == 90.0 else math.cos(math.radians(angle_deg))


# ----------------------------------------------------------------------------- sections
def _resolution(ctx: FieldChecker, v) -> tuple[int, int]:
    want = f"must be two integers in 1..{MAX_RESOLUTION}"
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        ctx.fail("resolution", f"{want} (got {jtype(v)} {show(v)})")
    out = []
    for i, x in enumerate(v):
        if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)) \
                or not 1 <= int(x) <= MAX_RESOLUTION:
            ctx.fail(f"resolution[{i}]", f"{want} (got {show(x)})")
        out.append(int(x))
    return out[0], out[1]


CAMERA_DEFAULTS = {"up": [0.0, 1.0, 0.0], "fov_y_deg": 60.0, "near": 0.1, "far": 1000.0}


def check_camera(ctx: FieldChecker, c: dict, field: str = "camera",
                 defaults: dict = CAMERA_DEFAULTS) -> Camera:
    """The one camera check: a scene file's camera, and each key of a camera path
    (scenes.camera_path, which gives no defaults: every field is required there).  The
    camera is stored as float64 (scenes.model.Camera): checked as float64."""
    ctx.keys(c, field, CAMERA_KEYS)
    get = lambda k: c.get(k, defaults[k]) if k in defaults else ctx.req(c, k, f"{field}.{k}")
    pos = ctx.vec3(get("position"), f"{field}.position", f32=False)
    tgt = ctx.vec3(get("target"), f"{field}.target", f32=False)
    up = ctx.direction(get("up"), f"{field}.up", f32=False)
    fov = ctx.num(get("fov_y_deg"), f"{field}.fov_y_deg", 0.0, 180.0, False, False, f32=False)
    near = ctx.num(get("near"), f"{field}.near", lo=0.0, lo_incl=False, f32=False)
    far = ctx.num(get("far"), f"{field}.far", lo=0.0, lo_incl=False, f32=False)
    if not far > near:
        ctx.fail(f"{field}.far", f"must be > {field}.near (got far {show(c.get('far'))}, "
                                 f"near {show(c.get('near'))})")
    if far / near > MAX_FAR_NEAR:
        ctx.fail(f"{field}.far", f"far/near must be <= {MAX_FAR_NEAR:g} (got {far / near:g})")
    view = np.subtract(tgt, pos)
    if not np.abs(view).max() > 0:
        ctx.fail(f"{field}.target", f"must differ from {field}.position (got {show(list(tgt))})")
    view = view / np.abs(view).max()
    view /= np.linalg.norm(view)
    if np.linalg.norm(np.cross(view, up)) < 1e-6:
        ctx.fail(f"{field}.up", f"must not be parallel to the view direction (got {show(c.get('up'))})")
    up_raw = tuple(float(x) for x in get("up"))
    return Camera(pos, tgt, up_raw, fov, near, far)


def _camera(ctx: FieldChecker, v) -> Camera:
    return check_camera(ctx, ctx.obj(v, "camera"))


def _material(ctx: FieldChecker, g: dict, field: str) -> dict:
    """The entry's Mesh material fields: albedo (default DEFAULT_ALBEDO), roughness and
    metallic (default 0: matte, dielectric), each in [0, 1]."""
    out = {key: ctx.num(g.get(key, 0.0), f"{field}.{key}", 0.0, 1.0)
           for key in ("roughness", "metallic")}
    out["albedo"] = DEFAULT_ALBEDO
    # opacity below 1: a transparent surface (app/pipeline/transparent.py), composited over the opaque
    out["opacity"] = ctx.num(g.get("opacity", 1.0), f"{field}.opacity", 0.0, 1.0)
    if "albedo" in g:
        a = ctx.vec3(g["albedo"], field + ".albedo", lo=0.0)
        out["albedo"] = tuple(ctx.num(x, f"{field}.albedo[{i}]", 0.0, 1.0) for i, x in enumerate(a))
    return out


def _matrix4(ctx: FieldChecker, v, field: str) -> np.ndarray:
    want = "must be a 4x4 array of finite numbers (row-major)"
    if not isinstance(v, (list, tuple)) or len(v) != 4 or \
            not all(isinstance(r, (list, tuple)) and len(r) == 4 for r in v):
        ctx.fail(field, f"{want} (got {show(v)})")
    m = np.array([[ctx.num(x, f"{field}[{i}][{j}]", f32=False) for j, x in enumerate(r)]
                  for i, r in enumerate(v)], np.float64)
    if not np.allclose(m[3], (0, 0, 0, 1), rtol=0, atol=1e-9):
        ctx.fail(f"{field}[3]", f"must be [0, 0, 0, 1]: affine, translation in the last column "
                                f"(got {show(m[3])})")
    return m


def _load_mesh(ctx: FieldChecker, g: dict, field: str) -> Mesh:
    rel, path = ctx.path(g["mesh"], field + ".mesh")
    m = _matrix4(ctx, g["transform"], field + ".transform") if "transform" in g else np.eye(4)
    material = _material(ctx, g, field)
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
    return Mesh(v.astype(np.float32), faces.astype(np.int32), **material)


def _geometry(ctx: FieldChecker, v) -> list[Mesh]:
    meshes = []
    every = _union(GEOMETRY_KEYS)
    elsewhere = _elsewhere(GEOMETRY_KEYS, "entries")
    for i, g in enumerate(ctx.arr(v, "geometry")):
        f = f"geometry[{i}]"
        ctx.obj(g, f)
        ctx.keys(g, f, every)
        kinds = [k for k in GEOMETRY_KEYS if k in g]
        if len(kinds) != 1:
            ctx.fail(f, f"must have exactly one of 'box' or 'mesh' (got keys {show(sorted(g))})")
        kind = kinds[0]
        ctx.keys(g, f, GEOMETRY_KEYS[kind], f"a {kind} entry", elsewhere)
        if kind == "box":
            b = ctx.obj(g["box"], f + ".box")
            ctx.keys(b, f + ".box", BOX_KEYS)
            lo = ctx.vec3(ctx.req(b, "min", f + ".box.min"), f + ".box.min")
            hi = ctx.vec3(ctx.req(b, "max", f + ".box.max"), f + ".box.max")
            for a in range(3):
                if to_f32(lo[a]) > to_f32(hi[a]):
                    ctx.fail(f + ".box.min", f"must be <= box.max on every axis "
                                             f"(got min {show(list(lo))} max {show(list(hi))})")
            material = _material(ctx, g, f)
            mesh = box_mesh(lo, hi, material["albedo"])
            mesh.roughness, mesh.metallic = material["roughness"], material["metallic"]
            mesh.opacity = material["opacity"]
            meshes.append(mesh)
        else:
            meshes.append(_load_mesh(ctx, g, f))
    return meshes


def _spot_cosines(ctx: FieldChecker, L: dict, f: str) -> tuple[float, float]:
    """(cos_inner, cos_outer) of a JSON spot, as float32 stores them."""
    fi, fo = f + ".inner_angle_deg", f + ".outer_angle_deg"
    inner = ctx.num(ctx.req(L, "inner_angle_deg", fi), fi, 0.0, 90.0, f32=False)
    outer = ctx.num(ctx.req(L, "outer_angle_deg", fo), fo, 0.0, 90.0, lo_incl=False, f32=False)
    if inner > outer:
        ctx.fail(fi, f"must be <= outer_angle_deg (got {inner:g} > {outer:g})")
    cos_inner, cos_outer = to_f32(cos_deg(inner)), to_f32(cos_deg(outer))
    if not cos_outer < 1.0:
        ctx.fail(fo, f"must be wide enough that cos(outer) < 1 in float32 (got {outer!r}: "
                     f"cos_outer rounds to 1.0, a cone that holds nothing)")
    return cos_inner, cos_outer       # cos is monotone: cos_inner >= cos_outer after rounding


def _box_axes(ctx: FieldChecker, direction: np.ndarray, L: dict, f: str) -> np.ndarray:
    """A box light's `up`, normalised; it must not be parallel to the direction as stored."""
    up = ctx.direction(ctx.req(L, "up", f + ".up"), f + ".up")
    d32, u32 = direction.astype(np.float32), up.astype(np.float32)
    if np.linalg.norm(np.cross(d32.astype(np.float64), u32.astype(np.float64))) < 1e-6:
        ctx.fail(f + ".up", f"must not be parallel to the direction (got {show(L['up'])})")
    return up


def _json_lights(ctx: FieldChecker, v) -> np.ndarray:
    items = ctx.arr(v, "lights")
    if len(items) > MAX_LIGHTS:
        ctx.fail("lights", f"at most {MAX_LIGHTS} lights (got {len(items)})")
    out = make_lights(len(items))
    every = _union(LIGHT_KEYS)
    elsewhere = _elsewhere(LIGHT_KEYS, "lights")
    for i, L in enumerate(items):
        f = f"lights[{i}]"
        ctx.obj(L, f)
        ctx.keys(L, f, every)
        t = ctx.req(L, "type", f + ".type")
        if not isinstance(t, str) or t not in LIGHT_TYPES:
            ctx.fail(f + ".type", f"unknown light type {show(t)} (expected one of: "
                                  f"{', '.join(LIGHT_TYPES)})")
        ctx.keys(L, f, LIGHT_KEYS[t], f"a {t} light", elsewhere)
        rec = out[i]
        rec["type"] = LIGHT_TYPES[t]
        rec["position"] = ctx.vec3(ctx.req(L, "position", f + ".position"), f + ".position")
        if t != "box":
            rec["radius"] = ctx.num(ctx.req(L, "radius", f + ".radius"), f + ".radius",
                                    0.0, MAX_RADIUS, lo_incl=False)
        if "color" in L:
            rec["color"] = ctx.vec3(L["color"], f + ".color", lo=0.0)
        if "intensity" in L:
            rec["intensity"] = ctx.num(L["intensity"], f + ".intensity", lo=0.0)
        if t == "point":
            continue
        direction = ctx.direction(ctx.req(L, "direction", f + ".direction"), f + ".direction")
        rec["direction"] = direction
        if t == "spot":
            rec["cos_inner"], rec["cos_outer"] = _spot_cosines(ctx, L, f)
        elif t == "capsule":
            rec["length"] = ctx.num(ctx.req(L, "length", f + ".length"), f + ".length",
                                    0.0, MAX_RADIUS)
        elif t == "box":
            rec["up"] = _box_axes(ctx, direction, L, f)
            fe = f + ".extent"
            e = ctx.req(L, "extent", fe)
            if not isinstance(e, (list, tuple)) or len(e) != 3:
                ctx.fail(fe, f"must be an array of 3 finite numbers in (0, {MAX_RADIUS:g}] "
                             f"(got {jtype(e)} {show(e)})")
            rec["extent"] = [ctx.num(x, f"{fe}[{k}]", 0.0, MAX_RADIUS, lo_incl=False)
                             for k, x in enumerate(e)]
            # radius is ignored for a box (docs/contracts.md "Light model"): it holds the box's bounding
            # sphere, so code that reads any light's radius stays conservative.
            rec["radius"] = np.linalg.norm(rec["extent"].astype(np.float64))
    return out


def _npz_lights(ctx: FieldChecker, v, n_json: int) -> np.ndarray:
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
        for k in z.files:
            if k not in NPZ_ARRAYS + NPZ_SHAPE_ARRAYS:
                ctx.fail("lights_npz", f"unknown array {show(k)} in {rel!r}"
                                       f"{suggest(k, NPZ_ARRAYS + NPZ_SHAPE_ARRAYS)}")
        for key in NPZ_ARRAYS:
            if key not in z.files:
                ctx.fail(f"lights_npz.{key}", f"missing array in {rel!r}")
        arrays = {}
        for key in NPZ_ARRAYS + tuple(k for k in NPZ_SHAPE_ARRAYS if k in z.files):
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
            want = (n, 3) if key in NPZ_VEC3 else (n,)
            if a.shape != want:
                ctx.fail(f, f"must have shape {want} to match lights_npz.type (got {a.shape})")
            arrays[key] = a
    t = arrays["type"]
    # The checks run on the float32 values the light buffer will hold.
    with np.errstate(over="ignore", invalid="ignore"):
        f32 = {k: a.astype(np.float32) for k, a in arrays.items() if k != "type"}

    def check(key, bad, want):
        bad = bad if bad.ndim == 1 else bad.any(axis=1)
        idx = np.flatnonzero(bad)
        if len(idx):
            i = int(idx[0])
            got, stored = arrays[key][i], f32[key][i] if key in f32 else None
            note = ""
            if stored is not None and not np.array_equal(np.asarray(got, np.float64),
                                                         stored.astype(np.float64)):
                note = f", {show(stored)} in float32"
            ctx.fail(f"lights_npz.{key}[{i}]", f"{want} (got {show(got)}{note})")

    check("type", ~np.isin(t, list(LIGHT_TYPES.values())),
          "must be a light type id: " + ", ".join(f"{i} ({n})" for n, i in LIGHT_TYPES.items()))
    spot, capsule, box = t == LIGHT_SPOT, t == LIGHT_CAPSULE, t == LIGHT_BOX
    for key in NPZ_SHAPE_ARRAYS:               # absent arrays are zeros (the contract)
        if key not in arrays:
            needed = np.flatnonzero(box if key != "length" else np.zeros(len(t), bool))
            if len(needed):
                ctx.fail(f"lights_npz.{key}", f"missing array in {rel!r}: box lights need it "
                                              f"(lights_npz.type[{int(needed[0])}] is a box)")
            arrays[key] = np.zeros((len(t), 3) if key in NPZ_VEC3 else len(t), np.float32)
            f32[key] = arrays[key]
    for key, a in f32.items():
        check(key, ~np.isfinite(a), "must be finite in float32")
    check("radius", ~box & ~((f32["radius"] > 0) & (f32["radius"] <= MAX_RADIUS)),
          f"must be a finite number in (0, {MAX_RADIUS:g}]")
    check("color", f32["color"] < 0, "must be >= 0")
    check("intensity", f32["intensity"] < 0, "must be >= 0")
    shaped = spot | capsule | box
    d = arrays["direction"].astype(np.float64)
    m = np.abs(d).max(axis=1)
    check("direction", shaped & ~(m > 0),
          "a spot, capsule or box light's direction must be a non-zero vector")
    ci, co = f32["cos_inner"], f32["cos_outer"]
    check("cos_inner", spot & ~((ci >= 0) & (ci <= 1)),
          "a spot light's cos_inner must be in [0, 1] in float32 (inner angle in [0, 90] degrees)")
    check("cos_outer", spot & ~((co >= 0) & (co < 1)),
          "a spot light's cos_outer must be in [0, 1) in float32 (outer angle in (0, 90] degrees)")
    check("cos_inner", spot & (ci < co), "must be >= cos_outer (inner angle <= outer angle)")
    check("length", capsule & ~((f32["length"] >= 0) & (f32["length"] <= MAX_RADIUS)),
          f"a capsule's length must be in [0, {MAX_RADIUS:g}]")
    check("extent", box[:, None] & ~((f32["extent"] > 0) & (f32["extent"] <= MAX_RADIUS)),
          f"a box light's half extents must be in (0, {MAX_RADIUS:g}]")
    dn = d.copy()
    if shaped.any():
        ds = d[shaped] / m[shaped, None]
        dn[shaped] = ds / np.linalg.norm(ds, axis=1, keepdims=True)
    up = arrays["up"].astype(np.float64)
    if box.any():
        mu = np.abs(up).max(axis=1)
        check("up", box & ~(mu > 0), "a box light's up must be a non-zero vector")
        ub = up[box] / mu[box, None]
        up[box] = ub / np.linalg.norm(ub, axis=1, keepdims=True)
        cross = np.cross(dn.astype(np.float32).astype(np.float64), up.astype(np.float32).astype(np.float64))
        check("up", box & (np.linalg.norm(cross, axis=1) < 1e-6),
              "a box light's up must not be parallel to its direction")
    out = np.zeros(len(t), LIGHT_DTYPE)
    out["type"] = t
    for key in ("position", "radius", "color", "intensity", "cos_inner", "cos_outer", "length",
                "extent"):
        out[key] = f32[key]
    out["direction"] = dn
    out["up"] = up
    # a box's radius is ignored (docs/contracts.md): it holds the box's bounding sphere (as JSON boxes)
    out["radius"][box] = np.linalg.norm(f32["extent"][box].astype(np.float64), axis=1)
    return out


# -------------------------------------------------------------------------------- API
def scene_from_dict(d, base_dir=None, source_name: str = "<scene>") -> Scene:
    """Validate a parsed JSON scene (docs/contracts.md) and build the Scene.

    `base_dir` resolves relative mesh / npz paths; `source_name` prefixes every error."""
    ctx = FieldChecker(str(source_name), base_dir)
    if not isinstance(d, dict):
        ctx.fail("top level", f"must be a JSON object (got {jtype(d)})")
    ctx.keys(d, "top level", TOP_KEYS)
    resolution = _resolution(ctx, ctx.req(d, "resolution", "resolution"))
    camera = _camera(ctx, ctx.req(d, "camera", "camera"))
    meshes = _geometry(ctx, d.get("geometry", []))
    lights = _json_lights(ctx, ctx.req(d, "lights", "lights"))
    if "lights_npz" in d:
        lights = np.concatenate([lights, _npz_lights(ctx, d["lights_npz"], len(lights))])
    name = Path(str(source_name)).stem or str(source_name)
    motion = _motion(ctx, d["motion"], meshes, lights) if "motion" in d else None
    fog = _fog(ctx, d["fog"], camera) if "fog" in d else None
    return Scene(name=name, resolution=resolution, camera=camera, meshes=meshes, lights=lights,
                 path=[], max_depth=max_depth_for([camera], meshes), motion=motion, fog=fog)


def _fog(ctx: FieldChecker, v, camera: Camera) -> Fog:
    """`fog` (scenes.model.Fog): a homogeneous medium from the near plane to view depth
    `far`: `density` >= 0 (extinction, 1/m), `albedo` in [0, 1] (a number or an RGB triple;
    default 0.9), `far` > the camera's near (default: the camera's far), `anisotropy` (the
    Henyey-Greenstein g) in (-1, 1) (default 0: isotropic)."""
    f = ctx.obj(v, "fog")
    ctx.keys(f, "fog", FOG_KEYS)
    density = ctx.num(ctx.req(f, "density", "fog.density"), "fog.density", 0.0, MAX_FOG_DENSITY)
    a = f.get("albedo", 0.9)
    if isinstance(a, (list, tuple)):
        albedo = ctx.vec3(a, "fog.albedo", lo=0.0)
        for i, x in enumerate(albedo):
            ctx.num(x, f"fog.albedo[{i}]", 0.0, 1.0)
    else:
        albedo = (ctx.num(a, "fog.albedo", 0.0, 1.0),) * 3
    far = ctx.num(f.get("far", camera.far), "fog.far", lo=0.0, lo_incl=False)
    if not far > camera.near:
        ctx.fail("fog.far", f"must be beyond camera.near ({camera.near:g}) (got {show(f.get('far'))})")
    if far / camera.near > MAX_FAR_NEAR:
        ctx.fail("fog.far", f"fog.far/camera.near must be <= {MAX_FAR_NEAR:g} (got {far / camera.near:g})")
    g = ctx.num(f.get("anisotropy", 0.0), "fog.anisotropy", -1.0, 1.0, False, False)
    return Fog(float(density), tuple(float(x) for x in albedo), float(far), float(g))


def _motion(ctx: FieldChecker, v, meshes, lights) -> Motion:
    """`motion` (scenes.motion): the lights bounce in `bounds` (default: the geometry's
    box), which must lie within the geometry's box and hold every light's position."""
    m = ctx.obj(v, "motion")
    ctx.keys(m, "motion", MOTION_KEYS)
    kind = ctx.req(m, "kind", "motion.kind")
    if kind not in MOTION_KINDS:
        ctx.fail("motion.kind", f"unknown motion {show(kind)} (expected one of: "
                                f"{', '.join(MOTION_KINDS)})")
    speed = ctx.num(ctx.req(m, "speed", "motion.speed"), "motion.speed", 0.0, MAX_SPEED)
    seed = m.get("seed", 0)
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) \
            or not 0 <= seed < 2 ** 63:
        ctx.fail("motion.seed", f"must be a non-negative integer (got {show(seed)})")
    if meshes:
        v_all = np.concatenate([mesh.vertices for mesh in meshes]).astype(np.float64)
        scene_lo, scene_hi = v_all.min(0), v_all.max(0)
    elif "bounds" not in m:
        ctx.fail("motion.bounds", "missing required key (the scene has no geometry whose box "
                                  "the lights could bounce in)")
    if "bounds" in m:
        b = ctx.obj(m["bounds"], "motion.bounds")
        ctx.keys(b, "motion.bounds", BOX_KEYS)
        lo = np.array(ctx.vec3(ctx.req(b, "min", "motion.bounds.min"), "motion.bounds.min"))
        hi = np.array(ctx.vec3(ctx.req(b, "max", "motion.bounds.max"), "motion.bounds.max"))
        if (lo > hi).any():
            ctx.fail("motion.bounds.min", f"must be <= bounds.max on every axis (got min "
                                          f"{show(lo.tolist())} max {show(hi.tolist())})")
        if meshes and ((lo < scene_lo).any() or (hi > scene_hi).any()):
            ctx.fail("motion.bounds", f"the motion leaves the scene's bounds {show(scene_lo.tolist())}"
                                      f"..{show(scene_hi.tolist())} (got {show(lo.tolist())}.."
                                      f"{show(hi.tolist())})")
    else:
        lo, hi = scene_lo, scene_hi
    bad = motion_outside(lights, lo, hi)
    if len(bad):
        i = int(bad[0])
        ctx.fail("motion", f"light {i} starts outside the motion's bounds {show(lo.tolist())}.."
                           f"{show(hi.tolist())}, so its motion would leave them (got position "
                           f"{show(lights['position'][i].tolist())}; {len(bad)} lights outside)")
    return Motion(str(kind), float(speed), int(seed), tuple(map(float, lo)), tuple(map(float, hi)))


def _json_file(path: Path, src: str) -> Scene:
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except (OSError, UnicodeDecodeError) as e:
        raise SceneError(f"{src}: cannot read: {one_line(e)}") from None
    try:
        d = json.loads(text)
    except json.JSONDecodeError as e:
        raise SceneError(f"{src}: line {e.lineno} col {e.colno}: invalid JSON: "
                         f"{one_line(e.msg)}") from None
    except RecursionError:
        raise SceneError(f"{src}: top level: invalid JSON: nested too deeply") from None
    return scene_from_dict(d, path.parent, src)


def load_scene(name_or_path: str, lights: int | None = None, seed: int = 0,
               distribution: str | None = None) -> Scene:
    """A builtin scene by name, or a scene file: JSON (the contract) or glTF 2.0 (`.gltf`,
    `.glb`; scenes/gltf.py).

    For a file, `lights=N` keeps the first N lights.  A file places its own lights, so the
    builtin scenes' draw arguments do not apply to it: a `distribution` is an error, and so is
    a `seed` other than the default 0 (0 is accepted, so a caller may pass its default seed
    through for any scene)."""
    src = str(name_or_path)
    if src in BUILTIN_SCENES:
        return BUILTIN_SCENES[src](lights, seed, distribution)
    if src in BUILTIN_VARIANTS:
        return BUILTIN_VARIANTS[src](lights, seed, distribution)
    path = Path(src)
    if not path.is_file():
        raise SceneError(f"{src}: not a builtin scene ({', '.join(BUILTIN_SCENES)}) "
                         f"and no such file")
    if distribution is not None:
        raise SceneError(f"{src}: distribution: applies to builtin scenes only; a scene file "
                         f"places its own lights (got {distribution!r})")
    if seed is not None and (isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer))
                             or seed != 0):
        raise SceneError(f"{src}: seed: applies to builtin scenes only; a scene file places its "
                         f"own lights (got {seed!r}; only the default 0 is accepted)")
    if path.suffix.lower() in GLTF_SUFFIXES:
        scene = load_gltf(path, src)
    else:
        scene = _json_file(path, src)
    if lights is not None:
        n = len(scene.lights)
        if isinstance(lights, bool) or not isinstance(lights, (int, np.integer)) \
                or not 0 <= lights <= n:
            raise SceneError(f"{src}: lights: --lights must be an integer in 0..{n}, "
                             f"the scene's light count (got {lights!r})")
        scene.lights = scene.lights[:int(lights)].copy()
    return scene
