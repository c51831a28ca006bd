"""Scene model: geometry, lights, camera and a deterministic camera path.

`scenes` produces scenes and nothing else: no OpenGL, no culling.

Lights are one structured numpy array (LIGHT_DTYPE), one row per light; a light's
id is its row index.  The light model (docs/contracts.md "Light model"): a light affects
a point only inside its finite volume:

    point    distance(P, position) < radius
    spot     the point's sphere, cut by the cone of half-angle acos(cos_outer) around direction
    capsule  distance(P, segment) < radius; the segment is centred at position, along
             direction, `length` long (0: a point light)
    box      P strictly inside the oriented box centred at position, axes
             right = normalize(cross(direction, up)), up' = cross(right, direction), direction,
             half extents `extent` (along right, up', direction); radius is ignored
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# The light type ids of the scene contract (docs/contracts.md "Contract: scene files"), defined here
# once: index = type id.  The CPU stage, the loader and the generated GLSL (LIGHT_SPOT ...)
# all read this tuple.
LIGHT_TYPES = ("point", "spot", "capsule", "box")
LIGHT_POINT = LIGHT_TYPES.index("point")
LIGHT_SPOT = LIGHT_TYPES.index("spot")
LIGHT_CAPSULE = LIGHT_TYPES.index("capsule")
LIGHT_BOX = LIGHT_TYPES.index("box")
LIGHT_TYPE_NAMES = dict(enumerate(LIGHT_TYPES))

LIGHT_DTYPE = np.dtype([
    ("type", np.uint8),
    ("position", np.float32, 3),
    ("radius", np.float32),
    ("color", np.float32, 3),
    ("intensity", np.float32),
    ("direction", np.float32, 3),   # unit vector: spot axis, capsule segment, box light direction
    ("cos_inner", np.float32),
    ("cos_outer", np.float32),
    ("length", np.float32),         # capsule segment length
    ("up", np.float32, 3),          # box: with direction, the box's orientation
    ("extent", np.float32, 3),      # box half extents along right, up', direction
], align=True)   # aligned fields: the CPU stage's numba kernels read records directly


def make_lights(n: int) -> np.ndarray:
    """An array of `n` lights with neutral defaults (white point lights)."""
    lights = np.zeros(n, LIGHT_DTYPE)
    lights["color"] = 1.0
    lights["intensity"] = 1.0
    lights["direction"] = (0.0, -1.0, 0.0)
    lights["cos_inner"] = 1.0
    lights["cos_outer"] = 1.0
    lights["up"] = (0.0, 0.0, -1.0)
    return lights


@dataclass(frozen=True)
class Camera:
    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov_y_deg: float = 60.0
    near: float = 0.1
    far: float = 1000.0


# The smallest GGX roughness shaded (Filament's minimum perceptual roughness): below it
# float32 GGX peaks to infinity at the mirror direction (glsl/material.glsl).
MIN_ROUGHNESS = 0.045


@dataclass
class Mesh:
    """World-space triangles with one material: albedo, and GGX specular when roughness > 0
    (F0 0.04, or the albedo when metallic is 1); roughness 0 is matte (Lambert only), a
    roughness in (0, MIN_ROUGHNESS) is raised to MIN_ROUGHNESS."""
    vertices: np.ndarray          # (V, 3) float32
    faces: np.ndarray             # (F, 3) int32
    albedo: tuple[float, float, float] = (0.8, 0.8, 0.8)
    roughness: float = 0.0
    metallic: float = 0.0
    # 1: opaque (the G-buffer).  Below 1 the mesh is a transparent surface: shaded after the
    # opaque pass in layers, back to front, and composited over it with this alpha.
    opacity: float = 1.0

    @property
    def transparent(self) -> bool:
        return self.opacity < 1.0

    def __setattr__(self, name, value):
        if name == "roughness" and 0.0 < value < MIN_ROUGHNESS:    # set at init or later
            value = MIN_ROUGHNESS
        super().__setattr__(name, value)

    @property
    def material(self) -> tuple:
        return tuple(self.albedo) + (float(self.roughness), float(self.metallic))


@dataclass(frozen=True)
class Fog:
    """A homogeneous participating medium from the near plane to view depth `far`:
    extinction `density` (1/m), single-scattering `albedo` (scattering = albedo * density),
    Henyey-Greenstein `anisotropy` g (0: isotropic)."""
    density: float
    albedo: tuple[float, float, float] = (0.9, 0.9, 0.9)
    far: float = 100.0
    anisotropy: float = 0.0


@dataclass
class Scene:
    name: str
    resolution: tuple[int, int]   # (width, height)
    camera: Camera
    meshes: list[Mesh]
    lights: np.ndarray            # LIGHT_DTYPE
    # Key cameras of the fly-through; camera_at() interpolates between them.
    path: list[Camera] = field(default_factory=list)
    # Farthest view depth worth slicing (tree paper 4: "maximum depth from the scene extents").
    max_depth: float | None = None
    # How the lights move along the path (scenes.motion.Motion; None: they stand still).
    motion: object | None = None
    # A homogeneous medium lit by the lights (Fog; None: clear air, no fog pass).
    fog: Fog | None = None

    def opaque_meshes(self) -> list[Mesh]:
        return [m for m in self.meshes if not m.transparent]

    def transparent_meshes(self) -> list[Mesh]:
        return [m for m in self.meshes if m.transparent]

    def lights_at(self, frame: int, frames: int = 64) -> np.ndarray:
        """The lights of frame `frame` of a `frames`-long loop: `self.lights` moved by
        `self.motion` (a pure function of scene, frame and frames; `self.lights` itself
        when nothing moves)."""
        from .motion import lights_at
        return lights_at(self.lights, self.motion, frame, frames)

    def camera_at(self, frame: int, frames: int = 64) -> Camera:
        """Camera of frame `frame` of a `frames`-long loop over `path` (frame 0 = self.camera)."""
        keys = [self.camera] + list(self.path)
        if len(keys) == 1 or frames <= 1:
            return self.camera
        t = (frame % frames) / frames * len(keys)
        i = int(t)
        a, b, f = keys[i % len(keys)], keys[(i + 1) % len(keys)], t - i
        lerp = lambda u, v: tuple(float(x + (y - x) * f) for x, y in zip(u, v))
        return Camera(lerp(a.position, b.position), lerp(a.target, b.target), a.up,
                      a.fov_y_deg, a.near, a.far)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World AABB of the geometry."""
        v = np.concatenate([m.vertices for m in self.meshes]) if self.meshes else np.zeros((1, 3))
        return v.min(0), v.max(0)

    def light_types(self) -> list[str]:
        """Names of the light types present, in type-id order (drives shader specialisation)."""
        return [LIGHT_TYPE_NAMES[t] for t in sorted(set(np.unique(self.lights["type"]).tolist()))]
