"""glTF 2.0 scenes (.gltf / .glb): every converted field checked numerically on a file these
tests write themselves, one-line errors for bad files, and a real model written by trimesh's
exporter (scenes/data/)."""
import base64
import json
import math
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from trimesh import transformations as tf

from scenes import LIGHT_DTYPE, SceneError, gltf, load_scene
from scenes.gltf import CUTOFF_T
from scenes.model import LIGHT_POINT, LIGHT_SPOT

ROOT = Path(__file__).resolve().parents[2]
ROOM = ROOT / "scenes" / "data" / "lab_room.glb"


# ------------------------------------------------------------------------------ a glTF writer
class Doc:
    """A minimal glTF writer: arrays appended to one buffer, 4-byte aligned."""

    def __init__(self):
        self.bin = bytearray()
        self.h = {"asset": {"version": "2.0"}, "buffers": [], "bufferViews": [], "accessors": [],
                  "meshes": [], "materials": [], "nodes": [], "scenes": [{"nodes": []}], "scene": 0}

    def view(self, data: bytes, stride=None) -> int:
        self.bin += b"\0" * (-len(self.bin) % 4)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if stride:
            v["byteStride"] = stride
        self.bin += data
        self.h["bufferViews"].append(v)
        return len(self.h["bufferViews"]) - 1

    def accessor(self, a: np.ndarray, kind: str, ctype: int, view=None, offset=0, count=None) -> int:
        if view is None:
            view = self.view(a.tobytes())
        acc = {"bufferView": view, "componentType": ctype, "count": count or len(a), "type": kind}
        if offset:
            acc["byteOffset"] = offset
        self.h["accessors"].append(acc)
        return len(self.h["accessors"]) - 1

    def positions(self, v) -> int:
        return self.accessor(np.asarray(v, np.float32), "VEC3", 5126)

    def indices(self, f, dtype=np.uint16) -> int:
        return self.accessor(np.asarray(f, dtype).reshape(-1), "SCALAR",
                             {np.uint8: 5121, np.uint16: 5123, np.uint32: 5125}[dtype])

    def mesh(self, *prims) -> int:
        self.h["meshes"].append({"primitives": list(prims)})
        return len(self.h["meshes"]) - 1

    def material(self, rgba) -> int:
        self.h["materials"].append({"pbrMetallicRoughness": {"baseColorFactor": list(rgba)}})
        return len(self.h["materials"]) - 1

    def node(self, root=True, **kw) -> int:
        self.h["nodes"].append(kw)
        i = len(self.h["nodes"]) - 1
        if root:
            self.h["scenes"][0]["nodes"].append(i)
        return i

    def write_gltf(self, path: Path) -> Path:
        h = json.loads(json.dumps(self.h))
        h["buffers"] = [{"byteLength": len(self.bin),
                         "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(self.bin)).decode()}]
        if not self.bin:
            del h["buffers"]
        path.write_text(json.dumps(h))
        return path

    def write_glb(self, path: Path) -> Path:
        h = json.loads(json.dumps(self.h))
        h["buffers"] = [{"byteLength": len(self.bin)}]
        if not self.bin:
            del h["buffers"]
        path.write_bytes(glb(h, bytes(self.bin) or None))
        return path


def glb(header: dict, binary: bytes | None) -> bytes:
    js = json.dumps(header).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js
    if binary is not None:
        binary = binary + b"\0" * (-len(binary) % 4)
        body += struct.pack("<II", len(binary), 0x004E4942) + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


CUBE = trimesh.creation.box(extents=(1, 1, 1))


def quat(axis, deg):
    """glTF quaternion [x, y, z, w] of a rotation by `deg` about `axis`."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    h = math.radians(deg) / 2
    return [*(a * math.sin(h)), math.cos(h)]


def trs(t=(0, 0, 0), q=(0, 0, 0, 1), s=(1, 1, 1)) -> np.ndarray:
    """T * R * S with trimesh's own quaternion code (w first): an independent reference."""
    return tf.translation_matrix(t) @ tf.quaternion_matrix([q[3], q[0], q[1], q[2]]) @ np.diag([*s, 1.0])


# The test scene: parents, TRS and matrix nodes, a mirrored node, a strided accessor, a strip,
# a multi-primitive mesh with a LINES primitive, a mesh under the camera node, two instances
# of one light, lights with and without range, a directional light, a camera node.
ROOT_T, ROOT_Q, ROOT_S = (10.0, 0.0, -4.0), quat((0, 1, 0), 90), (2.0, 2.0, 2.0)
CUBE_T = (0.0, 1.0, 0.0)
MIRROR = np.array([[-1, 0, 0, 3], [0, 1, 0, 0], [0, 0, 1, 2], [0, 0, 0, 1]], float)   # det < 0
CAM_T, CAM_Q = (1.0, 3.0, 12.0), quat((1, 1, 0), -12)
SPOT_T, SPOT_Q = (0.0, 6.0, -3.0), quat((1, 0, 0), -80)      # -Z turned towards -Y
COLORS = {"cube": (0.3, 0.5, 0.7, 1.0), "quad": (0.9, 0.1, 0.2, 0.5)}
LIGHTS = [
    {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 40.0, "range": 7.5},
    {"type": "spot", "color": [0.2, 0.4, 1.0], "intensity": 120.0,
     "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}},
    {"type": "directional", "color": [1, 1, 1], "intensity": 3.0},
    {"type": "point", "intensity": 2.0},                               # defaults: white, no range
    {"type": "spot", "intensity": 60.0, "range": 20.0, "spot": {}},   # defaults: inner 0, outer pi/4
    {"type": "spot", "intensity": 60.0, "range": 9.0,
     "spot": {"innerConeAngle": 0.0, "outerConeAngle": math.pi / 2}},  # a half-space cone
]


def build_doc() -> Doc:
    doc = Doc()
    m_cube = doc.material(COLORS["cube"])
    m_quad = doc.material(COLORS["quad"])
    cube = doc.mesh({"attributes": {"POSITION": doc.positions(CUBE.vertices)},
                     "indices": doc.indices(CUBE.faces), "material": m_cube})
    # the quad as a strip without indices, its positions interleaved with a dummy attribute
    quad = np.array([[0, 0, 0], [1, 0, 0], [0, 0, -1], [1, 0, -1]], np.float32)
    inter = np.concatenate([quad, np.full((4, 3), 7.0, np.float32)], 1)
    v = doc.view(inter.tobytes(), stride=24)
    strip = doc.mesh({"attributes": {"POSITION": doc.accessor(quad, "VEC3", 5126, view=v)},
                      "mode": 5, "material": m_quad})
    tri = np.array([[0, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    two = doc.mesh({"attributes": {"POSITION": doc.positions(tri)}, "indices": doc.indices([0, 1, 2], np.uint8)},
                   {"attributes": {"POSITION": doc.positions(tri)}, "mode": 1})
    doc.h["extensionsUsed"] = ["KHR_lights_punctual"]
    doc.h["extensions"] = {"KHR_lights_punctual": {"lights": json.loads(json.dumps(LIGHTS))}}
    doc.h["cameras"] = [{"type": "perspective",
                         "perspective": {"yfov": 0.8, "znear": 0.05, "zfar": 200.0, "aspectRatio": 2.0}}]
    light = lambda k: {"extensions": {"KHR_lights_punctual": {"light": k}}}
    # node 0: parent (TRS) of the cube (1) and the mirrored quad (2)
    doc.node(translation=list(ROOT_T), rotation=ROOT_Q, scale=list(ROOT_S), children=[1, 2])
    doc.node(root=False, mesh=cube, translation=list(CUBE_T))
    doc.node(root=False, mesh=strip, matrix=MIRROR.T.reshape(-1).tolist())
    doc.node(translation=[1.0, 2.0, 3.0], **light(0))                               # 3
    doc.node(translation=list(SPOT_T), rotation=SPOT_Q, **light(1))                 # 4
    doc.node(rotation=quat((1, 0, 0), -45), **light(2))                             # 5 directional
    doc.node(translation=list(CAM_T), rotation=CAM_Q, camera=0, children=[7])       # 6 camera
    doc.node(root=False, mesh=two, translation=[0.0, 0.0, -5.0])                    # 7 under it
    doc.node(translation=[-6.0, 1.0, 0.0], **light(3))                              # 8
    doc.node(translation=[0.0, 0.0, 0.0], children=[10])                            # 9
    doc.node(root=False, translation=[4.0, 0.5, 0.0], **light(0))                   # 10: light 0 again
    doc.node(translation=[0.0, 8.0, 0.0], rotation=quat((0, 0, 1), 30), **light(4))  # 11
    doc.node(translation=[2.0, 4.0, 2.0], rotation=quat((1, 0, 0), -90), **light(5))  # 12
    return doc


def world(node: int) -> np.ndarray:
    root = trs(ROOT_T, ROOT_Q, ROOT_S)
    return {0: root, 1: root @ trs(CUBE_T), 2: root @ MIRROR, 6: trs(CAM_T, CAM_Q),
            7: trs(CAM_T, CAM_Q) @ trs((0, 0, -5))}[node]


def apply(m, v):
    return np.asarray(v, float) @ m[:3, :3].T + m[:3, 3]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("gltf")
    doc = build_doc()
    return doc.write_gltf(d / "test.gltf"), doc.write_glb(d / "test.glb")


def triangles(mesh) -> set:
    """The mesh's triangles as a set of rounded vertex triples (rotation kept: winding counts)."""
    out = set()
    for f in mesh.faces:
        t = [tuple(np.round(mesh.vertices[i].astype(float), 4)) for i in f]
        k = t.index(min(t))
        out.add(tuple(t[k:] + t[:k]))
    return out


def expected_triangles(m, verts, faces, flip=False) -> set:
    v = apply(m, verts)
    fake = trimesh.Trimesh(v.astype(np.float32), np.asarray(faces)[:, ::-1] if flip else faces, process=False)
    return triangles(fake)


# ------------------------------------------------------------------------------ the scene
def test_gltf_scene_converted(files, capsys):
    gltf_path, _ = files
    s = load_scene(str(gltf_path))
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"{gltf_path}: warning: skipped 1 point or line primitive (no surface); "
                   f"1 directional light (no finite volume holds them)"], err
    assert s.name == "test"
    assert s.resolution == (1080, 540)                 # aspectRatio 2 at height 540

    # camera: node 6's world origin, -Z view, +Y up; yfov in degrees; znear, zfar
    c, m = s.camera, world(6)
    np.testing.assert_allclose(c.position, CAM_T, atol=1e-12)
    view = np.subtract(c.target, c.position)
    np.testing.assert_allclose(view / np.linalg.norm(view), -m[:3, 2], atol=1e-12)
    np.testing.assert_allclose(c.up, m[:3, 1], atol=1e-12)
    assert c.fov_y_deg == pytest.approx(math.degrees(0.8), abs=1e-12)
    assert (c.near, c.far) == (0.05, 200.0)

    # geometry: merged by albedo; every triangle where the node transforms put it
    by_albedo = {m.albedo: m for m in s.meshes}
    # albedo = baseColorFactor RGB exactly as written (0.3 stays 0.3, not 77/255); white default
    assert sorted(by_albedo) == sorted([COLORS["cube"][:3], COLORS["quad"][:3], (1.0, 1.0, 1.0)])
    for mesh in s.meshes:
        assert mesh.vertices.dtype == np.float32 and mesh.faces.dtype == np.int32
    assert triangles(by_albedo[COLORS["cube"][:3]]) == expected_triangles(world(1), CUBE.vertices, CUBE.faces)
    quad = np.array([[0, 0, 0], [1, 0, 0], [0, 0, -1], [1, 0, -1]], float)
    strip_faces = [[0, 1, 2], [2, 1, 3]]                 # strip order, every other one flipped
    assert triangles(by_albedo[COLORS["quad"][:3]]) == expected_triangles(world(2), quad, strip_faces, flip=True)
    tri = np.array([[0, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    assert triangles(by_albedo[(1.0, 1.0, 1.0)]) == expected_triangles(world(7), tri, [[0, 1, 2]])
    # winding: the source quad's faces face +Y; under the mirrored node (det < 0) the loader
    # flips the winding, so they still face +Y (the rotation about Y keeps Y)
    q = by_albedo[COLORS["quad"][:3]]
    t = q.vertices[q.faces].astype(float)
    assert np.linalg.det(world(2)[:3, :3]) < 0
    assert np.all(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])[:, 1] > 0)
    lo, hi = s.bounds()
    assert s.max_depth == pytest.approx(min(200.0, max(np.linalg.norm(np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]) - CAM_T, axis=1))))

    # lights, in walk order: node 3 (light 0), 4 (1), [5 directional skipped], 8 (3), 10 (0), 11 (4), 12 (5)
    L = s.lights
    assert L.dtype == LIGHT_DTYPE and len(L) == 6
    assert L["type"].tolist() == [LIGHT_POINT, LIGHT_SPOT, LIGHT_POINT, LIGHT_POINT, LIGHT_SPOT, LIGHT_SPOT]
    np.testing.assert_allclose(L["position"], [[1, 2, 3], SPOT_T, [-6, 1, 0], [4, 0.5, 0], [0, 8, 0], [2, 4, 2]],
                               atol=1e-6)
    np.testing.assert_array_equal(L["color"], np.float32([[1, 0.5, 0.25], [0.2, 0.4, 1], [1, 1, 1],
                                                          [1, 0.5, 0.25], [1, 1, 1], [1, 1, 1]]))
    np.testing.assert_array_equal(L["intensity"], np.float32([40, 120, 2, 40, 60, 60]))   # candela x 1
    # radius: range where given; the cutoff rule otherwise, I_ref = the brightest (120 x 1.0)
    i_ref = 120.0
    exp_radius = [7.5, math.sqrt(120 / (CUTOFF_T * i_ref) - 1), math.sqrt(2 / (CUTOFF_T * i_ref) - 1),
                  7.5, 20.0, 9.0]
    np.testing.assert_array_equal(L["radius"], np.float32(exp_radius))
    # spot directions: each node's world -Z
    spot_m = trs(SPOT_T, SPOT_Q)
    np.testing.assert_allclose(L["direction"][1], -spot_m[:3, 2], atol=1e-6)
    np.testing.assert_allclose(L["direction"][4], -trs((0, 8, 0), quat((0, 0, 1), 30))[:3, 2], atol=1e-6)
    np.testing.assert_allclose(L["direction"][5], [0, -1, 0], atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(L["direction"], axis=1), 1, atol=1e-6)
    np.testing.assert_array_equal(L["cos_inner"][[1, 4, 5]], np.float32([math.cos(0.2), 1.0, 1.0]))
    np.testing.assert_array_equal(L["cos_outer"][[1, 4, 5]], np.float32([math.cos(0.6), math.cos(math.pi / 4), 0.0]))
    # point lights keep the neutral defaults of make_lights for the spot-only fields
    assert np.all(L["cos_inner"][[0, 2, 3]] == 1) and np.all(L["cos_outer"][[0, 2, 3]] == 1)


def test_glb_equals_gltf(files, capsys):
    a, b = (load_scene(str(p)) for p in files)
    assert a.resolution == b.resolution and a.camera == b.camera and a.max_depth == b.max_depth
    np.testing.assert_array_equal(a.lights, b.lights)
    assert len(a.meshes) == len(b.meshes)
    for x, y in zip(a.meshes, b.meshes):
        assert x.albedo == y.albedo
        np.testing.assert_array_equal(x.vertices, y.vertices)
        np.testing.assert_array_equal(x.faces, y.faces)


def test_cutoff_rule_matches_the_benchmark(files, capsys):
    """The radius of a light without range is the benchmark's cutoff radius at t = 1/256
    (app/bench/cutoff.py, reimplemented in scenes/gltf.py)."""
    from app.bench.cutoff import cutoff_lights
    s = load_scene(str(files[0]))
    L = s.lights
    ref = cutoff_lights(L, CUTOFF_T)            # every light, I_ref = the brightest
    assert len(ref) == len(L)
    no_range = [1, 2]
    np.testing.assert_allclose(L["radius"][no_range], ref["radius"][no_range], rtol=1e-6)


def test_lights_option_and_draw_arguments(files, capsys):
    s = load_scene(str(files[1]), lights=2)
    assert len(s.lights) == 2 and s.lights["type"].tolist() == [LIGHT_POINT, LIGHT_SPOT]
    with pytest.raises(SceneError, match=r"test\.glb: distribution: "):
        load_scene(str(files[1]), distribution="uniform")
    with pytest.raises(SceneError, match=r"test\.glb: seed: "):
        load_scene(str(files[1]), seed=4)


# ------------------------------------------------------------------------------ materials
def test_metallic_roughness_factors_become_the_ggx_material(tmp_path):
    """metallicFactor / roughnessFactor as written, glTF's defaults (1, 1) where absent and for
    a primitive without a material, and roughness 0 (a mirror) raised to MIN_ROUGHNESS."""
    doc = Doc()
    pbr = [{"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.35},
           {"baseColorFactor": [0.2, 0.3, 0.4, 1.0]},
           {"baseColorFactor": [0.9, 0.8, 0.1, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.0}]
    doc.h["materials"] = [{"pbrMetallicRoughness": m} for m in pbr]
    for k in range(4):
        prim = {"attributes": {"POSITION": doc.positions(CUBE.vertices + [3 * k, 0, 0])},
                "indices": doc.indices(CUBE.faces)}
        if k < 3:
            prim["material"] = k
        doc.node(mesh=doc.mesh(prim))
    s = load_scene(str(doc.write_glb(tmp_path / "materials.glb")))
    got = {m.albedo: (m.roughness, m.metallic) for m in s.meshes}
    assert got == {(0.5, 0.5, 0.5): (0.35, 0.0), (0.2, 0.3, 0.4): (1.0, 1.0),
                   (0.9, 0.8, 0.1): (gltf.MIN_ROUGHNESS, 1.0), (1.0, 1.0, 1.0): (1.0, 1.0)}


def test_specular_materials_compile_and_render_exact(tmp_path, gl):
    """A glTF scene's GGX materials compile the specular code and keep techniques exact."""
    from app.pipeline.renderer import Renderer
    from tests.helpers import assert_exact, render_on
    with Renderer(load_scene(str(ROOM)), size=(160, 90)) as r:
        res = render_on(r, techniques=["brute", "clustered", "fptl"])
    assert "specular" in res["brute"].meta["features"]
    assert_exact(res, "lab_room")


# ------------------------------------------------------------------------------ defaults
def _single_mesh_doc(**camera):
    doc = Doc()
    doc.node(mesh=doc.mesh({"attributes": {"POSITION": doc.positions(CUBE.vertices * [4, 2, 6] + [1, 1, -3])},
                            "indices": doc.indices(CUBE.faces, np.uint32)}))
    if camera:
        doc.h["cameras"] = [camera]
        doc.node(translation=[0.0, 1.0, 20.0], camera=0)
    return doc


def test_default_camera_frames_the_bounds(tmp_path, capsys):
    s = load_scene(str(_single_mesh_doc().write_glb(tmp_path / "nocam.glb")))
    assert capsys.readouterr().err == ""          # nothing skipped: no warning line
    assert s.resolution == (960, 540) and len(s.lights) == 0
    m = s.meshes[0]                                 # glTF's default material: white rough metal
    assert (m.albedo, m.roughness, m.metallic) == ((1.0, 1.0, 1.0), 1.0, 1.0)
    lo, hi = s.bounds()
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    c = s.camera
    np.testing.assert_allclose(c.target, centre)
    off = np.subtract(c.position, centre)
    assert np.linalg.norm(off) == pytest.approx(radius / math.sin(math.radians(30)))
    assert math.degrees(math.asin(off[1] / np.linalg.norm(off))) == pytest.approx(20)
    assert off[0] == pytest.approx(0) and off[2] > 0 and c.up == (0.0, 1.0, 0.0) and c.fov_y_deg == 60
    assert c.near < np.linalg.norm(off) - radius and c.far > np.linalg.norm(off) + radius
    # every bounds corner is inside the view frustum
    f = -off / np.linalg.norm(off)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    d = corners - c.position
    cosang = d @ f / np.linalg.norm(d, axis=1)
    assert np.all(cosang > math.cos(math.radians(30)))


def test_infinite_projection_and_orthographic_cameras(tmp_path, capsys):
    doc = _single_mesh_doc(type="perspective", perspective={"yfov": 1.0, "znear": 0.5})
    s = load_scene(str(doc.write_glb(tmp_path / "inf.glb")))
    lo, hi = s.bounds()
    far_corner = max(np.linalg.norm(np.array([x, y, z]) - (0, 1, 20))
                     for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2]))
    assert s.camera.far == max(1000.0, 2 * far_corner) and s.camera.near == 0.5
    assert s.resolution == (960, 540)
    doc.h["cameras"].insert(0, {"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "zfar": 9, "znear": 0.1}})
    doc.h["nodes"][-1]["camera"] = 1
    doc.node(translation=[0.0, 0.0, 5.0], camera=0)          # after the perspective node
    capsys.readouterr()
    s2 = load_scene(str(doc.write_glb(tmp_path / "ortho.glb")))
    assert s2.camera.position == (0.0, 1.0, 20.0)
    doc.h["nodes"][1]["camera"] = 0                          # only orthographic cameras left
    capsys.readouterr()
    s3 = load_scene(str(doc.write_glb(tmp_path / "ortho2.glb")))
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "2 orthographic cameras (not supported; default view)" in err[0], err
    assert s3.camera.fov_y_deg == 60


def test_empty_scene_and_scene_less_file(tmp_path, capsys):
    doc = Doc()
    doc.h["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 5}]}}
    doc.node(translation=[1.0, 2.0, 3.0], extensions={"KHR_lights_punctual": {"light": 0}})
    del doc.h["scenes"], doc.h["scene"]             # no scenes: every root node is drawn
    s = load_scene(str(doc.write_gltf(tmp_path / "lights_only.gltf")))
    assert s.meshes == [] and len(s.lights) == 1
    assert s.lights["radius"][0] == np.float32(math.sqrt(255))   # the brightest light: sqrt(1/t - 1)
    np.testing.assert_allclose(s.camera.target, [1, 2, 3])


def test_mesh_instanced_by_two_nodes(tmp_path, capsys):
    doc = _single_mesh_doc()
    doc.node(mesh=0, translation=[0.0, 10.0, 0.0], scale=[1.0, 1.0, 0.5])
    s = load_scene(str(doc.write_glb(tmp_path / "twice.glb")))
    (m,) = s.meshes                                   # one albedo: merged into one mesh
    assert len(m.faces) == 2 * len(CUBE.faces)
    v = CUBE.vertices * [4, 2, 6] + [1, 1, -3]
    expected = expected_triangles(np.eye(4), v, CUBE.faces) | \
        expected_triangles(trs((0, 10, 0), s=(1, 1, 0.5)), v, CUBE.faces)
    assert triangles(m) == expected


def test_too_dim_lights_are_skipped_with_the_warning(tmp_path, capsys):
    doc = _single_mesh_doc()
    doc.h["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "point", "intensity": 256.0}, {"type": "point", "intensity": 1.0},
        {"type": "point", "intensity": 0.0}, {"type": "directional"}, {"type": "directional"}]}}
    for k in range(5):
        doc.node(extensions={"KHR_lights_punctual": {"light": k}})
    s = load_scene(str(doc.write_glb(tmp_path / "dim.glb")))
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "2 directional lights" in err[0] and "2 lights without range too dim" in err[0], err
    assert len(s.lights) == 1 and s.lights["intensity"][0] == 256


# ------------------------------------------------------------------------------ bad files
def _mutated(tmp_path, mutate, name="bad.glb"):
    doc = build_doc()
    out = mutate(doc)
    if isinstance(out, bytes):
        p = tmp_path / name
        p.write_bytes(out)
        return p
    return doc.write_glb(tmp_path / name) if name.endswith(".glb") else doc.write_gltf(tmp_path / name)


def _set(path, value):
    def mutate(doc):
        obj = doc.h
        for k in path[:-1]:
            obj = obj[k]
        obj[path[-1]] = value
    return mutate


def _truncated(doc):
    return glb({**doc.h, "buffers": [{"byteLength": len(doc.bin)}]}, bytes(doc.bin))[:-40]


def _nan_vertex(doc):
    start = doc.h["bufferViews"][doc.h["accessors"][0]["bufferView"]]["byteOffset"]
    doc.bin[start + 4:start + 8] = struct.pack("<f", float("nan"))


BAD = [
    ("nan_vertex", _nan_vertex, "accessors[0]: holds non-finite positions (used by meshes[0].primitives[0])"),
    ("not_gltf_json", lambda doc: b"{not json", "line 1 col 2: invalid JSON"),
    ("glb_truncated", _truncated, "GLB header: file is truncated"),
    ("glb_version_1", lambda doc: struct.pack("<4sII", b"glTF", 1, 12), "GLB header: version must be 2"),
    ("missing_asset", lambda doc: doc.h.pop("asset"), "asset: missing required key"),
    ("gltf_1", _set(["asset", "version"], "1.0"), "asset.version:"),
    ("required_draco", _set(["extensionsRequired"], ["KHR_draco_mesh_compression"]),
     "extensionsRequired[0]: extension 'KHR_draco_mesh_compression' is not supported"),
    ("buffer_too_short", lambda doc: glb({**doc.h, "buffers": [{"byteLength": 10 ** 6}]}, bytes(doc.bin)),
     "buffers[0].byteLength: is 1000000 but the data holds"),
    ("buffer_without_data", lambda doc: glb({**doc.h, "buffers": [{"byteLength": 8}]}, None),
     "buffers[0]: has no uri and the file has no GLB binary chunk"),
    ("view_outside_buffer", _set(["bufferViews", 0, "byteOffset"], 10 ** 6), "bufferViews[0]:"),
    ("accessor_past_view", _set(["accessors", 0, "count"], 10 ** 5), "accessors[0]:"),
    ("accessor_index_invalid", _set(["meshes", 0, "primitives", 0, "attributes", "POSITION"], 99),
     "meshes[0].primitives[0].attributes.POSITION:"),
    ("quantized_positions", _set(["accessors", 0, "componentType"], 5123), "accessors[0].componentType:"),
    ("sparse_accessor", _set(["accessors", 0, "sparse"], {"count": 1}), "accessors[0].sparse:"),
    ("index_past_vertices", lambda doc: doc.h["accessors"][0].update(count=4),
     "meshes[0].primitives[0].indices: holds index"),
    ("triangles_not_multiple_of_3", lambda doc: doc.h["accessors"][1].update(count=35),
     "meshes[0].primitives[0].indices: TRIANGLES need a multiple of 3"),
    ("fan", _set(["meshes", 0, "primitives", 0, "mode"], 6), "meshes[0].primitives[0].mode: TRIANGLE_FAN"),
    ("material_invalid", _set(["meshes", 0, "primitives", 0, "material"], 9),
     "meshes[0].primitives[0].material:"),
    ("base_color_over_one", _set(["materials", 0, "pbrMetallicRoughness", "baseColorFactor"], [1.5, 0, 0, 1]),
     "materials[0].pbrMetallicRoughness.baseColorFactor[0]:"),
    ("metallic_over_one", _set(["materials", 0, "pbrMetallicRoughness", "metallicFactor"], 1.01),
     "materials[0].pbrMetallicRoughness.metallicFactor:"),
    ("roughness_negative", _set(["materials", 1, "pbrMetallicRoughness", "roughnessFactor"], -0.1),
     "materials[1].pbrMetallicRoughness.roughnessFactor:"),
    ("roughness_not_number", _set(["materials", 0, "pbrMetallicRoughness", "roughnessFactor"], "0.5"),
     "materials[0].pbrMetallicRoughness.roughnessFactor:"),
    ("node_cycle", _set(["nodes", 1, "children"], [0]), "nodes[0]: is reached twice"),
    ("node_child_invalid", _set(["nodes", 0, "children"], [1, 77]), "nodes[0].children[1]:"),
    ("node_children_not_array", _set(["nodes", 9, "children"], 10), "nodes[9].children: must be an array"),
    ("matrix_and_trs", _set(["nodes", 2, "translation"], [0, 0, 0]), "nodes[2]: has both 'matrix'"),
    ("rotation_zero", _set(["nodes", 4, "rotation"], [0, 0, 0, 0]), "nodes[4].rotation:"),
    ("translation_nan", _set(["nodes", 3, "translation"], [0, float("nan"), 0]), "nodes[3].translation[1]:"),
    ("light_index_invalid", _set(["nodes", 3, "extensions", "KHR_lights_punctual", "light"], 42),
     "nodes[3].extensions.KHR_lights_punctual.light:"),
    ("light_type_unknown", _set(["extensions", "KHR_lights_punctual", "lights", 0, "type"], "area"),
     "extensions.KHR_lights_punctual.lights[0].type:"),
    ("light_intensity_negative", _set(["extensions", "KHR_lights_punctual", "lights", 0, "intensity"], -1),
     "extensions.KHR_lights_punctual.lights[0].intensity:"),
    ("light_intensity_inf32", _set(["extensions", "KHR_lights_punctual", "lights", 0, "intensity"], 1e39),
     "extensions.KHR_lights_punctual.lights[0].intensity:"),
    ("light_range_zero", _set(["extensions", "KHR_lights_punctual", "lights", 0, "range"], 0),
     "extensions.KHR_lights_punctual.lights[0].range:"),
    ("light_range_zero32", _set(["extensions", "KHR_lights_punctual", "lights", 0, "range"], 1e-46),
     "extensions.KHR_lights_punctual.lights[0].range:"),
    ("spot_missing", lambda doc: doc.h["extensions"]["KHR_lights_punctual"]["lights"][1].pop("spot"),
     "extensions.KHR_lights_punctual.lights[1].spot: missing"),
    ("spot_outer_over_90", _set(["extensions", "KHR_lights_punctual", "lights", 1, "spot", "outerConeAngle"], 1.6),
     "extensions.KHR_lights_punctual.lights[1].spot.outerConeAngle:"),
    ("spot_outer_zero", _set(["extensions", "KHR_lights_punctual", "lights", 1, "spot", "outerConeAngle"], 0),
     "extensions.KHR_lights_punctual.lights[1].spot.outerConeAngle:"),
    ("spot_outer_rounds_to_cos_1", _set(["extensions", "KHR_lights_punctual", "lights", 1, "spot"],
                                        {"innerConeAngle": 0, "outerConeAngle": 1e-5}),
     "extensions.KHR_lights_punctual.lights[1].spot.outerConeAngle: must be wide enough"),
    ("spot_inner_over_outer", _set(["extensions", "KHR_lights_punctual", "lights", 1, "spot", "innerConeAngle"], 0.7),
     "extensions.KHR_lights_punctual.lights[1].spot.innerConeAngle:"),
    ("spot_node_collapsed", _set(["nodes", 4, "scale"], [1, 1, 0]), "nodes[4]: the node's transform collapses"),
    ("camera_yfov_zero", _set(["cameras", 0, "perspective", "yfov"], 0), "cameras[0].perspective.yfov:"),
    ("camera_zfar_le_znear", _set(["cameras", 0, "perspective", "zfar"], 0.01), "cameras[0].perspective.zfar:"),
    ("camera_type", _set(["cameras", 0, "type"], "fisheye"), "cameras[0].type:"),
    ("camera_aspect_absurd", _set(["cameras", 0, "perspective", "aspectRatio"], 1000.0),
     "cameras[0].perspective.aspectRatio:"),
    ("scene_index_invalid", _set(["scene"], 3), "scene:"),
]


@pytest.mark.parametrize("mutate, field", [pytest.param(m, f, id=i) for i, m, f in BAD])
def test_bad_gltf_rejected(tmp_path, mutate, field):
    p = _mutated(tmp_path, mutate)
    with pytest.raises(SceneError) as ei:
        load_scene(str(p))
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith(f"{p}: "), msg
    assert field in msg, msg


@pytest.mark.parametrize("uri, field", [
    ("missing.bin", "buffers[0].uri: cannot read 'missing.bin'"),
    ("data:application/octet-stream;base64,@@@", "buffers[0].uri: invalid base64"),
])
def test_bad_gltf_buffer_uri(tmp_path, uri, field):
    doc = build_doc()
    p = doc.write_gltf(tmp_path / "b.gltf")
    h = json.loads(p.read_text())
    h["buffers"][0]["uri"] = uri
    p.write_text(json.dumps(h))
    with pytest.raises(SceneError) as ei:
        load_scene(str(p))
    assert str(ei.value).startswith(f"{p}: {field}"), str(ei.value)


def test_external_buffer_file(tmp_path, capsys):
    doc = build_doc()
    (tmp_path / "sub dir").mkdir()
    (tmp_path / "sub dir" / "data.bin").write_bytes(bytes(doc.bin))
    h = json.loads(json.dumps(doc.h))
    h["buffers"] = [{"byteLength": len(doc.bin), "uri": "sub%20dir/data.bin"}]
    (tmp_path / "ext.gltf").write_text(json.dumps(h))
    s = load_scene(str(tmp_path / "ext.gltf"))
    ref = load_scene(str(doc.write_glb(tmp_path / "ref.glb")))
    np.testing.assert_array_equal(s.lights, ref.lights)
    assert [len(m.faces) for m in s.meshes] == [len(m.faces) for m in ref.meshes]


def test_bad_gltf_through_the_cli_is_one_line_exit_2(tmp_path):
    p = _mutated(tmp_path, _set(["extensions", "KHR_lights_punctual", "lights", 0, "range"], -2))
    r = subprocess.run([sys.executable, "-m", "app.capture", "--scene", str(p), "--technique", "brute"],
                       cwd=ROOT, capture_output=True, text=True, timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "extensions.KHR_lights_punctual.lights[0].range" in lines[0]


# ------------------------------------------------------------------------------ a real model
def test_real_model_from_trimesh_exporter(capsys):
    """scenes/data/lab_room.glb: written by trimesh's glTF exporter (no .glb/.gltf ships with
    any installed package), see scenes/data/README.md."""
    s = load_scene(str(ROOM))
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "1 directional light" in err[0], err
    assert s.name == "lab_room" and s.resolution == (960, 540)
    assert 500 < sum(len(m.faces) for m in s.meshes) < 5000
    lo, hi = s.bounds()
    np.testing.assert_allclose(lo[[0, 2]], [-10, -10], atol=1e-5)
    np.testing.assert_allclose(hi[[0, 2]], [10, 10], atol=1e-5)
    assert lo[1] == pytest.approx(-0.1, abs=1e-5) and 2 < hi[1] < 8
    # trimesh writes baseColorFactor as 8-bit values / 255: the loader keeps them exactly
    assert all(all(round(a * 255) == pytest.approx(a * 255, abs=1e-9) for a in m.albedo) for m in s.meshes)
    # rough dielectrics, a glossy sphere and a metal torus (make_lab_room.py)
    assert sorted({(m.roughness, m.metallic) for m in s.meshes}) == [(0.3, 0.0), (0.4, 1.0), (0.8, 0.0)]
    L = s.lights
    assert L["type"].tolist() == [LIGHT_POINT] * 8 + [LIGHT_SPOT] * 2
    # bulbs: no range, cutoff radius against the brightest light (a spot, 40 cd, white)
    bulbs = np.array([6.0, 9.0, 12.0, 6.0, 9.0, 12.0, 6.0, 9.0])
    np.testing.assert_array_equal(L["intensity"][:8], np.float32(bulbs))
    np.testing.assert_allclose(L["radius"][:8], np.sqrt(bulbs / (CUTOFF_T * 40.0) - 1), rtol=1e-6)
    np.testing.assert_array_equal(L["radius"][8:], [12, 12])
    np.testing.assert_allclose(np.linalg.norm(L["position"][:8, [0, 2]], axis=1), 7.5, rtol=1e-6)
    # the spots aim at the crate and the sphere
    for k, target in ((8, (-2.5, 0.0, -3.0)), (9, (0.0, 0.0, 1.5))):
        to = np.subtract(target, L["position"][k])
        np.testing.assert_allclose(L["direction"][k], to / np.linalg.norm(to), atol=1e-6)
    c = s.camera
    assert c.fov_y_deg == pytest.approx(50.0) and c.near == pytest.approx(0.1) and c.far == pytest.approx(100.0)
    view = np.subtract(c.target, c.position)
    assert view[1] < 0 and view[2] < 0               # looking down into the room
