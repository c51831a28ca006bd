"""glTF 2.0 scenes (`.gltf`, `.glb`) -> Scene (docs/contracts.md "Contract: scene files").

What is read, and how it converts (every rule below is this lab's, stated once here):

- **Scene and nodes.**  The scene `scene` (else `scenes[0]`; a file without scenes: every root
  node), walked depth first, children in order.  A node's local transform is its `matrix`
  (column-major) or T * R * S; world = parent world * local.  Axes and units need no
  conversion: glTF is right-handed, +Y up, metres, cameras and lights look down their node's
  -Z, exactly as this lab.
- **Geometry.**  Each mesh instance's TRIANGLES and TRIANGLE_STRIP primitives, in world space,
  one `Mesh` each, then merged by material (fewer draws).  POINTS and LINES primitives hold no
  surface and are left out (counted in the warning line); TRIANGLE_FAN is refused.  A node
  whose transform has a negative determinant gets its winding flipped (glTF rule).  Skins and
  morph targets are ignored (the bind pose is drawn).
- **Material.**  The primitive's `material.pbrMetallicRoughness`: albedo = baseColorFactor RGB
  exactly as written; metallic = metallicFactor and roughness = roughnessFactor (glTF's
  defaults 1 and 1, and its default material, white rough metal, without a material), onto
  the lab's GGX material (glsl/material.glsl: F0 0.04 mixed to the albedo by metallic, the
  same metallic-roughness model).  A roughness below MIN_ROUGHNESS (0.045, Filament's
  smallest perceptual roughness; scenes.model, as for every scene) is raised to it: glTF's 0
  is a perfect mirror, a delta no light loop evaluates, and the lab's roughness 0 means
  matte (no specular code).
  Textures and vertex colours are not used; alpha only as `alphaMode: BLEND`, whose
  baseColorFactor alpha is the mesh's opacity (a transparent surface, app/pipeline/transparent.py;
  OPAQUE and MASK surfaces are opaque: MASK's cutout needs the texture alpha, not read).
- **Lights** (`KHR_lights_punctual`), one per node that references one, in walk order:
  position = the node's world origin; a spot's direction = the node's world -Z, normalised;
  `color` as is (linear RGB); `intensity` (candela for point and spot) times
  INTENSITY_PER_CANDELA = 1: this lab's falloff I / (d^2 + 1) is glTF's inverse-square law
  I / d^2 softened inside 1 m, so candela carry over unchanged and the image shows
  albedo x illuminance (lux) with no exposure.  `range` becomes `radius`; a light without
  `range` gets its radius from the benchmark's cutoff rule (below).  Spot cones:
  innerConeAngle (default 0) and outerConeAngle (default pi/4), radians, stored as cosines
  (an outer angle of pi/2 stores cos_outer = 0).  The spot's angular falloff is this lab's
  smoothstep between the cosines, glTF's is a squared linear ramp: same cone, softer edge.
  Directional lights, which no finite volume holds, are skipped and counted in the warning.
- **Camera.**  The first node (walk order) with a perspective camera: position = node's world
  origin, view = world -Z, up = world +Y; fov_y_deg = degrees(yfov), near = znear, far = zfar
  (no zfar, an infinite projection: far = max(1000, twice the distance to the farthest corner
  of the geometry's bounds, 2 znear), at most 1e9 znear).  `aspectRatio` sets the resolution
  to round(540 x aspect) x 540, otherwise 960 x 540 (the builtin scenes' size); --size
  overrides either.  Orthographic cameras are not supported (counted in the warning).
  Without a camera: a default view, fov 60 degrees, looking at the centre of the geometry's
  bounds from +Z and 20 degrees above, at the distance where the bounding sphere fills the
  vertical field of view (near 1/100 of that distance, far twice the farthest bound); the
  lights' positions stand in for the bounds of a file without geometry.
- max_depth from the geometry and the camera, as for JSON scenes (geometry.max_depth_for).

The cutoff rule is the benchmark's (app/bench/cutoff.py `cutoff_lights`), reimplemented here
because `scenes` imports nothing from `app`: with I_i = intensity x brightest colour channel
and I_ref the brightest light of the file (point and spot lights, with or without range),
radius_i = sqrt(I_i / (t I_ref) - 1), where I_i / (d^2 + 1) falls to t I_ref, t = 1/256.  A
light never brighter than that (the benchmark drops it: I_i / (t I_ref) - 1 <= 1e-6) affects
nothing and is skipped, counted in the warning.

Decoding: trimesh (trimesh.exchange.gltf.load_gltf) decodes the primitives' POSITION and
index accessors (strides, 8/16/32-bit indices, strips).  It is handed a pruned copy of the
file: only the accessors and buffer views the drawn primitives use (checked here first, so a
malformed file fails with a line naming its field, and unused data cannot fail the load),
and one material per primitive whose name says which primitive it is.  This module does the
rest itself, because trimesh's scene graph stores baseColorFactor as 8-bit colour (0.3 comes
back as 77/255), ignores sparse accessors (they read as zeros), and leaves the subtree of a
camera node unattached (trimesh 5.2: Scene.dump() fails with "No path from world->...").

Keys this reader does not use (extras, extensions, animations, textures ...) are ignored: the
unknown-key rule belongs to the JSON scene contract, and glTF files carry many such keys.
Skipped things (directional lights, too-dim lights, orthographic cameras, point and line
primitives) make ONE warning line on stderr that counts them.  Every error is one line
`<file>: <glTF field>: <what is wrong>` (a SceneError).
"""
from __future__ import annotations

import base64
import binascii
import io
import json
import math
import struct
import sys
from pathlib import Path
from urllib.parse import unquote

import numpy as np

from .errors import (FLOAT32_MAX, MAX_FAR_NEAR, MAX_RADIUS, MAX_RESOLUTION, FieldChecker,
                     SceneError, finite32, jtype, one_line, show, to_f32)
from .geometry import farthest_corner_distance, max_depth_for, merge_meshes
from .model import LIGHT_POINT, LIGHT_SPOT, MIN_ROUGHNESS, Camera, Mesh, Scene, make_lights

GLTF_SUFFIXES = (".gltf", ".glb")
INTENSITY_PER_CANDELA = 1.0      # lab intensity per glTF candela (see the module docstring)
CUTOFF_T = 1.0 / 256.0           # the benchmark's cutoff threshold (app/bench/cutoff.py)
CUTOFF_MIN_Q = 1e-6              # ... and its "affects nothing" margin on I_i / (t I_ref) - 1
DEFAULT_HEIGHT = 540
DEFAULT_RESOLUTION = (960, DEFAULT_HEIGHT)
DEFAULT_FOV_Y_DEG = 60.0
DEFAULT_VIEW_ELEVATION_DEG = 20.0
INFINITE_FAR_MIN = 1000.0

GLB_MAGIC = b"glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942
MODE_NAMES = {0: "POINTS", 1: "LINES", 2: "LINE_LOOP", 3: "LINE_STRIP", 4: "TRIANGLES",
              5: "TRIANGLE_STRIP", 6: "TRIANGLE_FAN"}
TRIANGLE_MODES = (4, 5)
NO_SURFACE = "no surface"                  # a POINTS / LINES primitive
COMPONENT_SIZE = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
TYPE_SIZE = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
INDEX_TYPES = (5121, 5123, 5125)           # unsigned byte / short / int
# Required extensions this reader honours: lights are read here; material and texture
# extensions change shading this lab does not do (it reads the metallic-roughness factors).
SUPPORTED_REQUIRED = ("KHR_lights_punctual", "KHR_texture_transform", "KHR_texture_basisu",
                      "EXT_texture_webp", "KHR_materials_")


def _warn(source: str, notes: list[str]) -> None:
    if notes:
        print(f"{source}: warning: skipped {'; '.join(notes)}", file=sys.stderr)


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


# ------------------------------------------------------------------------------ container
def _read_document(ctx: FieldChecker, data: bytes) -> tuple[dict, bytes | None]:
    """(JSON header, GLB binary chunk or None) of a .glb or .gltf file."""
    binary = None
    if data[:4] == GLB_MAGIC:
        if len(data) < 12:
            ctx.fail("GLB header", f"file is truncated ({len(data)} bytes)")
        _, version, length = struct.unpack_from("<4sII", data, 0)
        if version != 2:
            ctx.fail("GLB header", f"version must be 2 (got {version})")
        if length > len(data):
            ctx.fail("GLB header", f"file is truncated: the header says {length} bytes, "
                                   f"the file has {len(data)}")
        chunks, off = [], 12
        while off + 8 <= length:
            size, kind = struct.unpack_from("<II", data, off)
            if off + 8 + size > length:
                ctx.fail(f"GLB chunk {len(chunks)}", f"is truncated ({size} bytes declared, "
                                                     f"{length - off - 8} left)")
            chunks.append((kind, data[off + 8:off + 8 + size]))
            off += 8 + size
        if not chunks or chunks[0][0] != CHUNK_JSON:
            ctx.fail("GLB chunk 0", "must be the JSON chunk")
        raw = chunks[0][1]
        binary = next((c for k, c in chunks[1:] if k == CHUNK_BIN), None)
    else:
        raw = data
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        ctx.fail("JSON", f"not UTF-8: {one_line(e)}")
    try:
        header = json.loads(text)
    except json.JSONDecodeError as e:
        ctx.fail(f"line {e.lineno} col {e.colno}", f"invalid JSON: {one_line(e.msg)}")
    except RecursionError:
        ctx.fail("top level", "invalid JSON: nested too deeply")
    if not isinstance(header, dict):
        ctx.fail("top level", f"must be a JSON object (got {jtype(header)})")
    return header, binary


def _index(ctx: FieldChecker, v, field: str, items: list, what: str) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < len(items):
        ctx.fail(field, f"must be an index into {what} (0..{len(items) - 1}) (got {show(v)})")
    return v


def _nodes_naming(ctx: FieldChecker, walk, nodes: list, key: str, items: list, what: str):
    """(node, its world matrix, the index it names, that item's field, the item) for every
    node of `walk` that names one of `items` by `key` (a node's "mesh" or "camera")."""
    for n, world in walk:
        if key in nodes[n]:
            i = _index(ctx, nodes[n][key], f"nodes[{n}].{key}", items, what)
            yield n, world, i, f"{what}[{i}]", ctx.obj(items[i], f"{what}[{i}]")


def _count(ctx: FieldChecker, v, field: str, lo: int = 0) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < lo:
        ctx.fail(field, f"must be an integer >= {lo} (got {show(v)})")
    return v


def _check_asset(ctx: FieldChecker, h: dict) -> None:
    asset = ctx.obj(ctx.req(h, "asset", "asset"), "asset")
    version = ctx.req(asset, "version", "asset.version")
    if not isinstance(version, str) or version.split(".")[0] != "2":
        ctx.fail("asset.version", f"must be a glTF 2.x version string (got {show(version)})")
    required = ctx.arr(h.get("extensionsRequired", []), "extensionsRequired")
    for i, ext in enumerate(required):
        if not isinstance(ext, str) or not any(ext == s or (s.endswith("_") and ext.startswith(s))
                                               for s in SUPPORTED_REQUIRED):
            ctx.fail(f"extensionsRequired[{i}]", f"extension {show(ext)} is not supported "
                                                 f"(supported: KHR_lights_punctual, material "
                                                 f"and texture extensions)")


def _buffers(ctx: FieldChecker, h: dict, binary: bytes | None) -> list[bytes]:
    out = []
    for i, b in enumerate(ctx.arr(h.get("buffers", []), "buffers")):
        f = f"buffers[{i}]"
        ctx.obj(b, f)
        size = _count(ctx, ctx.req(b, "byteLength", f + ".byteLength"), f + ".byteLength", 1)
        if "uri" in b:
            uri = b["uri"]
            if not isinstance(uri, str) or not uri:
                ctx.fail(f + ".uri", f"must be a non-empty string (got {show(uri)})")
            if uri.startswith("data:"):
                head, sep, payload = uri.partition(",")
                if not sep or not head.endswith(";base64"):
                    ctx.fail(f + ".uri", "a data URI must be base64 (data:...;base64,...)")
                try:
                    data = base64.b64decode(payload, validate=True)
                except (binascii.Error, ValueError) as e:
                    ctx.fail(f + ".uri", f"invalid base64 data: {one_line(e)}")
            else:
                rel = unquote(uri)
                p = ctx.base_dir / rel
                try:
                    data = p.read_bytes()
                except OSError as e:
                    ctx.fail(f + ".uri", f"cannot read {rel!r}: {type(e).__name__}: "
                                         f"{one_line(e.strerror or e)}")
        elif i == 0 and binary is not None:
            data = binary
        else:
            ctx.fail(f, "has no uri and the file has no GLB binary chunk for it")
        if len(data) < size:
            ctx.fail(f + ".byteLength", f"is {size} but the data holds {len(data)} bytes")
        out.append(data[:size])
    return out


# ------------------------------------------------------------------------------ node tree
def _quat_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _numbers(ctx: FieldChecker, v, field: str, n: int) -> np.ndarray:
    if not isinstance(v, (list, tuple)) or len(v) != n:
        ctx.fail(field, f"must be an array of {n} finite numbers (got {jtype(v)} {show(v)})")
    return np.array([ctx.num(x, f"{field}[{i}]", f32=False) for i, x in enumerate(v)], np.float64)


def _local(ctx: FieldChecker, node: dict, f: str) -> np.ndarray:
    trs = [k for k in ("translation", "rotation", "scale") if k in node]
    if "matrix" in node:
        if trs:
            ctx.fail(f, f"has both 'matrix' and {show(trs)}: a node takes one or the other")
        m = _numbers(ctx, node["matrix"], f + ".matrix", 16).reshape(4, 4).T   # column-major
        if not np.allclose(m[3], (0, 0, 0, 1), rtol=0, atol=1e-9):
            ctx.fail(f + ".matrix", f"must be affine: last row [0, 0, 0, 1] (got {show(m[3])})")
        return m
    m = np.eye(4)
    if "scale" in node:
        m[:3, :3] = np.diag(_numbers(ctx, node["scale"], f + ".scale", 3))
    if "rotation" in node:
        q = _numbers(ctx, node["rotation"], f + ".rotation", 4)
        n = np.linalg.norm(q)
        if not n > 0:
            ctx.fail(f + ".rotation", f"must be a non-zero quaternion [x, y, z, w] (got {show(q)})")
        m[:3, :3] = _quat_matrix(*(q / n)) @ m[:3, :3]
    if "translation" in node:
        m[:3, 3] = _numbers(ctx, node["translation"], f + ".translation", 3)
    return m


def _walk(ctx: FieldChecker, h: dict) -> list[tuple[int, np.ndarray]]:
    """[(node index, world matrix)] of the displayed scene, depth first, children in order."""
    nodes = ctx.arr(h.get("nodes", []), "nodes")
    for i, n in enumerate(nodes):
        ctx.obj(n, f"nodes[{i}]")
        ctx.arr(n.get("children", []), f"nodes[{i}].children")
    if "scenes" in h:
        scenes = ctx.arr(h["scenes"], "scenes")
        k = _index(ctx, h.get("scene", 0), "scene", scenes, "scenes")
        s = ctx.obj(scenes[k], f"scenes[{k}]")
        roots = ctx.arr(s.get("nodes", []), f"scenes[{k}].nodes")
        roots = [_index(ctx, r, f"scenes[{k}].nodes[{j}]", nodes, "nodes") for j, r in enumerate(roots)]
    else:
        children = {c for n in nodes for c in n.get("children", []) if isinstance(c, int)}
        roots = [i for i in range(len(nodes)) if i not in children]
    out, seen = [], set()
    stack = [(r, np.eye(4)) for r in reversed(roots)]
    while stack:
        i, parent = stack.pop()
        f = f"nodes[{i}]"
        if i in seen:
            ctx.fail(f, "is reached twice: the node hierarchy must be a set of disjoint trees")
        seen.add(i)
        with np.errstate(all="ignore"):
            world = parent @ _local(ctx, nodes[i], f)
        if not np.all(np.isfinite(world)):
            ctx.fail(f, "its world transform overflows")
        out.append((i, world))
        kids = ctx.arr(nodes[i].get("children", []), f + ".children")
        for j, c in reversed(list(enumerate(kids))):
            stack.append((_index(ctx, c, f"{f}.children[{j}]", nodes, "nodes"), world))
    return out


def _axis(m: np.ndarray, v) -> np.ndarray | None:
    """Unit world direction of the node-local vector `v`, None if the transform collapses it."""
    d = m[:3, :3] @ np.asarray(v, np.float64)
    n = np.linalg.norm(d)
    return d / n if n > 0 and np.isfinite(n) else None


# ------------------------------------------------------------------------------ geometry
def _accessor(ctx: FieldChecker, h: dict, buffers: list[bytes], idx, field: str, kinds,
              components) -> int:
    """Check that accessor `idx` is a plain (non-sparse) accessor of one of `kinds` x
    `components` whose bytes lie inside its buffer view and buffer; returns its index."""
    accessors = ctx.arr(h.get("accessors", []), "accessors")
    i = _index(ctx, idx, field, accessors, "accessors")
    f = f"accessors[{i}]"
    a = ctx.obj(accessors[i], f)
    if a.get("type") not in kinds:
        ctx.fail(f + ".type", f"must be {' or '.join(kinds)} here (got {show(a.get('type'))})")
    ct = a.get("componentType")
    if ct not in components:
        ctx.fail(f + ".componentType", f"must be one of {list(components)} here (got {show(ct)})"
                 + (" (quantized positions, KHR_mesh_quantization, are not supported)"
                    if kinds == ("VEC3",) else ""))
    if a.get("normalized"):
        ctx.fail(f + ".normalized", "normalized accessors are not supported here")
    if "sparse" in a:
        ctx.fail(f + ".sparse", "sparse accessors are not supported")
    count = _count(ctx, ctx.req(a, "count", f + ".count"), f + ".count", 1)
    if "bufferView" not in a:
        ctx.fail(f + ".bufferView", "missing (an accessor without data is all zeros)")
    views = ctx.arr(h.get("bufferViews", []), "bufferViews")
    v = _index(ctx, a["bufferView"], f + ".bufferView", views, "bufferViews")
    fv = f"bufferViews[{v}]"
    view = ctx.obj(views[v], fv)
    b = _index(ctx, ctx.req(view, "buffer", fv + ".buffer"), fv + ".buffer", buffers, "buffers")
    v_off = _count(ctx, view.get("byteOffset", 0), fv + ".byteOffset")
    v_len = _count(ctx, ctx.req(view, "byteLength", fv + ".byteLength"), fv + ".byteLength", 1)
    if v_off + v_len > len(buffers[b]):
        ctx.fail(fv, f"bytes {v_off}..{v_off + v_len} lie outside buffers[{b}] "
                     f"({len(buffers[b])} bytes)")
    elem = COMPONENT_SIZE[ct] * TYPE_SIZE[a["type"]]
    stride = _count(ctx, view.get("byteStride", elem), fv + ".byteStride", 1)
    if stride < elem:
        ctx.fail(fv + ".byteStride", f"must be >= the element size {elem} (got {stride})")
    a_off = _count(ctx, a.get("byteOffset", 0), f + ".byteOffset")
    end = a_off + (count - 1) * stride + elem
    if end > v_len:
        ctx.fail(f, f"its {count} elements end at byte {end}, past bufferViews[{v}] "
                    f"({v_len} bytes)")
    return i


ALPHA_MODES = ("OPAQUE", "MASK", "BLEND")    # glTF's material.alphaMode (default OPAQUE)


def _material(ctx: FieldChecker, h: dict, p: dict, f: str) -> tuple[tuple, float, float, float]:
    """(albedo RGB, roughness, metallic, opacity) of a primitive (module docstring,
    "Material")."""
    if "material" not in p:
        return (1.0, 1.0, 1.0), 1.0, 1.0, 1.0        # glTF's default material
    materials = ctx.arr(h.get("materials", []), "materials")
    k = _index(ctx, p["material"], f + ".material", materials, "materials")
    fm = f"materials[{k}]"
    mat = ctx.obj(materials[k], fm)
    pbr = ctx.obj(mat.get("pbrMetallicRoughness", {}), fm + ".pbrMetallicRoughness")
    fc = fm + ".pbrMetallicRoughness.baseColorFactor"
    c = pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])
    if not isinstance(c, (list, tuple)) or len(c) != 4:
        ctx.fail(fc, f"must be an array of 4 numbers in [0, 1] (got {jtype(c)} {show(c)})")
    rgba = [ctx.num(x, f"{fc}[{i}]", 0.0, 1.0) for i, x in enumerate(c)]
    fp = fm + ".pbrMetallicRoughness."
    metallic = ctx.num(pbr.get("metallicFactor", 1.0), fp + "metallicFactor", 0.0, 1.0)
    roughness = ctx.num(pbr.get("roughnessFactor", 1.0), fp + "roughnessFactor", 0.0, 1.0)
    mode = mat.get("alphaMode", "OPAQUE")
    if mode not in ALPHA_MODES:
        ctx.fail(fm + ".alphaMode", f"must be one of {', '.join(ALPHA_MODES)} (got {show(mode)})")
    opacity = float(rgba[3]) if mode == "BLEND" else 1.0
    return tuple(rgba[:3]), max(float(roughness), MIN_ROUGHNESS), float(metallic), opacity


def _decode(ctx: FieldChecker, h: dict, buffers: list[bytes], prims: list[tuple]) -> list:
    """[(vertices (V,3) float64, faces (F,3) int64)] of `prims` [(pos accessor, index accessor
    or None, mode, field, material)], decoded by trimesh from a pruned copy of the file."""
    from trimesh.exchange.gltf import load_gltf
    acc_map, view_map, accessors, views = {}, {}, [], []

    def add_view(v):
        if v not in view_map:
            view_map[v] = len(views)
            src = h["bufferViews"][v]
            views.append({k: src[k] for k in ("buffer", "byteOffset", "byteLength", "byteStride")
                          if k in src})
        return view_map[v]

    def add_accessor(a):
        if a not in acc_map:
            acc_map[a] = len(accessors)
            src = h["accessors"][a]
            accessors.append({"bufferView": add_view(src["bufferView"]),
                              "byteOffset": src.get("byteOffset", 0),
                              "componentType": src["componentType"], "count": src["count"],
                              "type": src["type"]})
        return acc_map[a]

    meshes = []
    for k, (pos, ind, mode, _, _) in enumerate(prims):
        p = {"attributes": {"POSITION": add_accessor(pos)}, "mode": mode, "material": k}
        if ind is not None:
            p["indices"] = add_accessor(ind)
        meshes.append({"name": f"p{k}", "primitives": [p]})
    pruned = {"asset": {"version": "2.0"},
              "buffers": [{"uri": f"lab-buffer-{i}", "byteLength": len(b)} for i, b in enumerate(buffers)],
              "bufferViews": views, "accessors": accessors, "meshes": meshes,
              "materials": [{"name": f"lab-primitive-{k}"} for k in range(len(prims))]}
    resolver = {f"lab-buffer-{i}": b for i, b in enumerate(buffers)}
    try:
        kw = load_gltf(io.BytesIO(json.dumps(pruned).encode()), resolver=resolver)
    except Exception as e:  # noqa: BLE001 - any decoder failure is a bad file
        ctx.fail("meshes", f"cannot decode the mesh data: {type(e).__name__}: {one_line(e)}")
    out = [None] * len(prims)
    for g in kw["geometry"].values():
        k = int(g["visual"].material.name.rsplit("-", 1)[1])
        out[k] = (np.asarray(g["vertices"], np.float64), np.asarray(g["faces"], np.int64))
    for k, (pos, ind, mode, f, _) in enumerate(prims):
        if out[k] is None:
            ctx.fail(f, "trimesh decoded no triangles for this primitive")
        v, faces = out[k]
        if not np.all(np.isfinite(v)):
            ctx.fail(f"accessors[{pos}]", f"holds non-finite positions (used by {f})")
        if faces.size and (faces.min() < 0 or faces.max() >= len(v)):
            ctx.fail(f + ".indices", f"holds index {int(faces.max())} past the {len(v)} vertices "
                                     f"of accessors[{pos}]")
    return out


def _geometry(ctx: FieldChecker, h: dict, buffers: list[bytes], walk, notes: list) -> list[Mesh]:
    gltf_meshes = ctx.arr(h.get("meshes", []), "meshes")
    nodes = h.get("nodes", [])
    prims = []            # each (mesh, primitive) once: (POSITION, indices, mode, field, material)
    index = {}            # (mesh, primitive) -> its row in prims, NO_SURFACE, or None (empty)
    instances = []        # (row in prims, node world matrix, node)
    skipped = 0
    for n, world, mi, fm, m in _nodes_naming(ctx, walk, nodes, "mesh", gltf_meshes, "meshes"):
        for j, p in enumerate(ctx.arr(ctx.req(m, "primitives", fm + ".primitives"), fm + ".primitives")):
            if (mi, j) not in index:
                row = _primitive(ctx, h, buffers, p, f"{fm}.primitives[{j}]")
                if isinstance(row, tuple):
                    prims.append(row)
                    row = len(prims) - 1
                index[(mi, j)] = row
            row = index[(mi, j)]
            if row == NO_SURFACE:
                skipped += 1
            elif row is not None:
                instances.append((row, world, n))
    if skipped:
        notes.append(_plural(skipped, "point or line primitive") + " (no surface)")
    if not prims:
        return []
    decoded = _decode(ctx, h, buffers, prims)
    out = []
    for k, world, n in instances:
        v, faces = decoded[k]
        if not len(faces):
            continue
        with np.errstate(all="ignore"):
            w = v @ world[:3, :3].T + world[:3, 3]
        if not np.all(np.abs(w) <= FLOAT32_MAX):
            ctx.fail(f"nodes[{n}]", "its transformed vertices overflow float32")
        if np.linalg.det(world[:3, :3]) < 0:
            faces = faces[:, ::-1]
        out.append(Mesh(w.astype(np.float32), np.ascontiguousarray(faces, np.int32), *prims[k][4]))
    return merge_meshes(out)


def _primitive(ctx: FieldChecker, h: dict, buffers: list[bytes], p, f: str):
    """(POSITION, indices or None, mode, field, material) of a triangle primitive, checked;
    NO_SURFACE for points and lines, None for a strip of fewer than 3 vertices."""
    ctx.obj(p, f)
    mode = p.get("mode", 4)
    if mode not in MODE_NAMES:
        ctx.fail(f + ".mode", f"must be a primitive mode 0..6 (got {show(mode)})")
    if mode not in TRIANGLE_MODES:
        if mode == 6:
            ctx.fail(f + ".mode", "TRIANGLE_FAN (6) is not supported")
        return NO_SURFACE
    attrs = ctx.obj(ctx.req(p, "attributes", f + ".attributes"), f + ".attributes")
    pos = _accessor(ctx, h, buffers, ctx.req(attrs, "POSITION", f + ".attributes.POSITION"),
                    f + ".attributes.POSITION", ("VEC3",), (5126,))
    ind = None
    count = h["accessors"][pos]["count"]
    if "indices" in p:
        ind = _accessor(ctx, h, buffers, p["indices"], f + ".indices", ("SCALAR",), INDEX_TYPES)
        count = h["accessors"][ind]["count"]
    if mode == 4 and count % 3:
        ctx.fail(f + (".indices" if ind is not None else ".attributes.POSITION"),
                 f"TRIANGLES need a multiple of 3 vertices (got {count})")
    material = _material(ctx, h, p, f)
    if mode == 5 and count < 3:
        return None
    return (pos, ind, mode, f, material)


# ------------------------------------------------------------------------------ lights
def _cos_rad(a: float) -> float:
    return 0.0 if a >= math.pi / 2 else math.cos(a)


def _light_def(ctx: FieldChecker, L, f: str) -> dict:
    ctx.obj(L, f)
    t = ctx.req(L, "type", f + ".type")
    if t not in ("point", "spot", "directional"):
        ctx.fail(f + ".type", f"must be 'point', 'spot' or 'directional' (got {show(t)})")
    out = {"type": t,
           "color": ctx.vec3(L.get("color", [1.0, 1.0, 1.0]), f + ".color", lo=0.0),
           "intensity": ctx.num(L.get("intensity", 1.0), f + ".intensity", lo=0.0),
           "range": None}
    if t == "directional":
        return out
    if "range" in L:
        out["range"] = ctx.num(L["range"], f + ".range", 0.0, MAX_RADIUS, lo_incl=False)
    if t == "spot":
        s = ctx.obj(ctx.req(L, "spot", f + ".spot"), f + ".spot")
        fi, fo = f + ".spot.innerConeAngle", f + ".spot.outerConeAngle"
        # Writers that work in float32 store pi/2 as 1.5707964: allowed, read as pi/2.
        top = math.pi / 2 + 1e-6
        inner = ctx.num(s.get("innerConeAngle", 0.0), fi, 0.0, top, f32=False)
        outer = ctx.num(s.get("outerConeAngle", math.pi / 4), fo, 0.0, top, lo_incl=False, f32=False)
        if inner > outer:
            ctx.fail(fi, f"must be <= outerConeAngle (got {inner!r} > {outer!r})")
        out["cos_inner"], out["cos_outer"] = to_f32(_cos_rad(inner)), to_f32(_cos_rad(outer))
        if not out["cos_outer"] < 1.0:
            ctx.fail(fo, f"must be wide enough that cos(outer) < 1 in float32 (got {outer!r}: "
                         f"cos_outer rounds to 1.0, a cone that holds nothing)")
    return out


def _lights(ctx: FieldChecker, h: dict, walk, notes: list) -> np.ndarray:
    nodes = h.get("nodes", [])
    ext = ctx.obj(h.get("extensions", {}), "extensions")
    fl = "extensions.KHR_lights_punctual.lights"
    defs_raw = ctx.arr(ctx.obj(ext.get("KHR_lights_punctual", {}), "extensions.KHR_lights_punctual")
                       .get("lights", []), fl)
    defs: dict[int, dict] = {}
    rows, directional = [], 0
    for n, world in walk:
        node_ext = ctx.obj(nodes[n].get("extensions", {}), f"nodes[{n}].extensions")
        if "KHR_lights_punctual" not in node_ext:
            continue
        fn = f"nodes[{n}].extensions.KHR_lights_punctual"
        ref = ctx.obj(node_ext["KHR_lights_punctual"], fn)
        k = _index(ctx, ctx.req(ref, "light", fn + ".light"), fn + ".light", defs_raw, fl)
        if k not in defs:
            defs[k] = _light_def(ctx, defs_raw[k], f"{fl}[{k}]")
        d = defs[k]
        if d["type"] == "directional":
            directional += 1
            continue
        pos = world[:3, 3]
        if not all(finite32(x) for x in pos):
            ctx.fail(f"nodes[{n}]", f"the light's position overflows float32 (got {show(pos)})")
        direction = (0.0, -1.0, 0.0)
        if d["type"] == "spot":
            direction = _axis(world, (0.0, 0.0, -1.0))
            if direction is None:
                ctx.fail(f"nodes[{n}]", "the node's transform collapses its -Z axis: a spot "
                                        "light needs a direction")
        rows.append((d, pos, direction))
    if directional:
        notes.append(_plural(directional, "directional light") + " (no finite volume holds them)")
    lights = make_lights(len(rows))
    if not rows:
        return lights
    peak = np.array([d["intensity"] * INTENSITY_PER_CANDELA * max(d["color"]) for d, _, _ in rows])
    i_ref = float(peak.max())
    keep = np.ones(len(rows), bool)
    for i, (d, pos, direction) in enumerate(rows):
        rec = lights[i]
        rec["type"] = LIGHT_SPOT if d["type"] == "spot" else LIGHT_POINT
        rec["position"] = pos
        rec["color"] = d["color"]
        rec["intensity"] = d["intensity"] * INTENSITY_PER_CANDELA
        rec["direction"] = direction
        if d["type"] == "spot":
            rec["cos_inner"], rec["cos_outer"] = d["cos_inner"], d["cos_outer"]
        if d["range"] is not None:
            rec["radius"] = d["range"]
            continue
        # The benchmark's cutoff rule (app/bench/cutoff.py), t = 1/256: see the docstring.
        q = peak[i] / (CUTOFF_T * i_ref) - 1.0 if i_ref > 0 else -1.0
        if q > CUTOFF_MIN_Q:
            rec["radius"] = math.sqrt(q)
        else:
            keep[i] = False
    if not keep.all():
        notes.append(_plural(int((~keep).sum()), "light") + " without range too dim for the "
                     "cutoff rule (intensity x colour <= 1/256 of the brightest light's)")
    return lights[keep]


# ------------------------------------------------------------------------------ camera
def _bounds(meshes: list[Mesh], lights: np.ndarray):
    if meshes:
        v = np.concatenate([m.vertices for m in meshes]).astype(np.float64)
    elif len(lights):
        v = lights["position"].astype(np.float64)
    else:
        v = np.zeros((1, 3))
    return v.min(0), v.max(0)


def _default_camera(meshes: list[Mesh], lights: np.ndarray) -> Camera:
    lo, hi = _bounds(meshes, lights)
    centre = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 1e-3 * max(1.0, float(np.abs(centre).max())), 1e-3)
    dist = radius / math.sin(math.radians(DEFAULT_FOV_Y_DEG) / 2)
    e = math.radians(DEFAULT_VIEW_ELEVATION_DEG)
    pos = centre + dist * np.array([0.0, math.sin(e), math.cos(e)])
    return Camera(tuple(map(float, pos)), tuple(map(float, centre)), (0.0, 1.0, 0.0),
                  DEFAULT_FOV_Y_DEG, 0.01 * dist, 2.0 * (dist + radius))


def _camera(ctx: FieldChecker, h: dict, walk, meshes: list[Mesh], lights: np.ndarray,
            notes: list) -> tuple[Camera, tuple[int, int]]:
    nodes = h.get("nodes", [])
    cameras = ctx.arr(h.get("cameras", []), "cameras")
    ortho = 0
    for n, world, k, fc, cam in _nodes_naming(ctx, walk, nodes, "camera", cameras, "cameras"):
        t = ctx.req(cam, "type", fc + ".type")
        if t == "orthographic":
            ortho += 1
            continue
        if t != "perspective":
            ctx.fail(fc + ".type", f"must be 'perspective' or 'orthographic' (got {show(t)})")
        fp = fc + ".perspective"
        p = ctx.obj(ctx.req(cam, "perspective", fp), fp)
        yfov = ctx.num(ctx.req(p, "yfov", fp + ".yfov"), fp + ".yfov", 0.0, math.pi, False, False, f32=False)
        near = ctx.num(ctx.req(p, "znear", fp + ".znear"), fp + ".znear", lo=0.0, lo_incl=False, f32=False)
        pos = world[:3, 3]
        fwd, up = _axis(world, (0.0, 0.0, -1.0)), _axis(world, (0.0, 1.0, 0.0))
        if fwd is None or up is None or np.linalg.norm(np.cross(fwd, up)) < 1e-6 \
                or not all(finite32(x) for x in pos):
            ctx.fail(f"nodes[{n}]", "the camera node's transform is degenerate (its -Z and +Y "
                                    "axes must be non-zero, not parallel, position finite)")
        if "zfar" in p:
            far = ctx.num(p["zfar"], fp + ".zfar", lo=0.0, lo_incl=False, f32=False)
            if not far > near:
                ctx.fail(fp + ".zfar", f"must be > znear (got zfar {far!r}, znear {near!r})")
            if far / near > MAX_FAR_NEAR:
                ctx.fail(fp + ".zfar", f"zfar/znear must be <= {MAX_FAR_NEAR:g} (got {far / near:g})")
        else:                                   # infinite projection: a far plane past the scene
            far = max(INFINITE_FAR_MIN, 2.0 * farthest_corner_distance(pos, meshes), 2.0 * near)
            far = min(far, near * MAX_FAR_NEAR)
        resolution = DEFAULT_RESOLUTION
        if "aspectRatio" in p:
            aspect = ctx.num(p["aspectRatio"], fp + ".aspectRatio", lo=0.0, lo_incl=False, f32=False)
            width = int(round(DEFAULT_HEIGHT * aspect))
            if not 1 <= width <= MAX_RESOLUTION:
                ctx.fail(fp + ".aspectRatio", f"gives a width of {width} pixels at height "
                                              f"{DEFAULT_HEIGHT}, outside 1..{MAX_RESOLUTION}")
            resolution = (width, DEFAULT_HEIGHT)
        if ortho:
            notes.append(_plural(ortho, "orthographic camera") + " (not supported)")
        return (Camera(tuple(map(float, pos)), tuple(map(float, pos + fwd)), tuple(map(float, up)),
                       math.degrees(yfov), near, far), resolution)
    if ortho:
        notes.append(_plural(ortho, "orthographic camera") + " (not supported; default view)")
    return _default_camera(meshes, lights), DEFAULT_RESOLUTION


# ------------------------------------------------------------------------------ API
def load_gltf(path, source: str | None = None) -> Scene:
    """A Scene from a glTF 2.0 file (.gltf or .glb); errors are one-line SceneErrors naming
    `source` (default: the path) and the glTF field."""
    path = Path(path)
    ctx = FieldChecker(str(source if source is not None else path), path.parent)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise SceneError(f"{ctx.source}: cannot read: {one_line(e)}") from None
    header, binary = _read_document(ctx, data)
    _check_asset(ctx, header)
    buffers = _buffers(ctx, header, binary)
    walk = _walk(ctx, header)
    notes: list[str] = []
    meshes = _geometry(ctx, header, buffers, walk, notes)
    lights = _lights(ctx, header, walk, notes)
    camera, resolution = _camera(ctx, header, walk, meshes, lights, notes)
    _warn(ctx.source, notes)
    return Scene(name=path.stem, resolution=resolution, camera=camera, meshes=meshes,
                 lights=lights, path=[], max_depth=max_depth_for([camera], meshes))
