"""Procedural builtin scenes.

Each builder is `build(lights: int | None, seed: int, distribution: str | None) -> Scene`:
`lights=None` is the scene's default count, `distribution` is "uniform" (positions uniform in
the scene's box, tree paper "CTF-TitanPass") or "geometry" (near random triangles, tree paper
"EpicCitadel"), None = the scene's default.  The geometry does not depend on the seed; the
lights are drawn from np.random.default_rng(seed), so equal arguments give bit-identical scenes.
Units are metres, +y is up.  Triangle counts stay in the low thousands (software rasterizer).
"""
from __future__ import annotations

import numpy as np

from .geometry import box_mesh, max_depth_for, merge_meshes, ramp_mesh
from .lights import _fill_common, on_geometry, sample_on_geometry, sample_radii, spot_lights, uniform_in_box
from .errors import MAX_LIGHTS, SceneError
from .model import LIGHT_BOX, LIGHT_CAPSULE, Camera, Fog, Mesh, Scene, make_lights

DISTRIBUTIONS = ("uniform", "geometry")
RESOLUTION = (960, 540)


def _check_args(name: str, lights, seed, distribution, default_lights: int, default_dist: str):
    if lights is None:
        lights = default_lights
    if isinstance(lights, bool) or not isinstance(lights, (int, np.integer)):
        raise SceneError(f"{name}: lights: must be an integer (got {lights!r})")
    if not 0 <= int(lights) <= MAX_LIGHTS:
        raise SceneError(f"{name}: lights: must be in 0..{MAX_LIGHTS} (got {lights})")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SceneError(f"{name}: seed: must be a non-negative integer (got {seed!r})")
    if distribution is None:
        distribution = default_dist
    if distribution not in DISTRIBUTIONS:
        raise SceneError(f"{name}: distribution: must be one of {', '.join(DISTRIBUTIONS)} "
                         f"(got {distribution!r})")
    return int(lights), np.random.default_rng(int(seed)), distribution


def _cams(keys, fov=60.0, near=0.1, far=1000.0) -> list[Camera]:
    return [Camera(tuple(map(float, p)), tuple(map(float, t)), (0.0, 1.0, 0.0), fov, near, far)
            for p, t in keys]


def _aabb(meshes: list[Mesh]):
    v = np.concatenate([m.vertices for m in meshes]).astype(np.float64)
    return v.min(0), v.max(0)


def _distribute(n, distribution, meshes, lo, hi, rng, radius_range) -> np.ndarray:
    if distribution == "uniform":
        return uniform_in_box(n, lo, hi, rng, radius_range)
    return on_geometry(n, meshes, rng, radius_range)


def _finish(name, cams, meshes, lights) -> Scene:
    meshes = merge_meshes(meshes)
    return Scene(name=name, resolution=RESOLUTION, camera=cams[0], meshes=meshes,
                 lights=lights, path=cams[1:], max_depth=max_depth_for(cams, meshes))


# ----------------------------------------------------------------------------------- city
CITY_LENGTH = 1900.0        # the street runs from z=+40 to z=-CITY_LENGTH
CITY_CROSS_STREETS = np.arange(-200.0, -CITY_LENGTH, -240.0)   # centre z of cross streets


def _city_geometry() -> list[Mesh]:
    g = np.random.default_rng(1001)           # fixed layout
    palette = [(0.62, 0.60, 0.56), (0.55, 0.52, 0.50), (0.70, 0.66, 0.58),
               (0.45, 0.47, 0.52), (0.75, 0.72, 0.68)]
    street = box_mesh((-160, -1, -CITY_LENGTH - 120), (160, 0, 60), (0.35, 0.35, 0.36),
                      bottom=False)
    street.roughness = 0.35                   # wet asphalt: GGX highlights of the lights
    meshes = [street]
    half_street = 12.0
    for side in (-1.0, 1.0):
        for row, (x0, depth, hmin, hmax) in enumerate(((half_street, (18, 32), 8, 70),
                                                       (half_street + 40, (25, 45), 20, 140))):
            z = 40.0
            while z > -CITY_LENGTH:
                width = g.uniform(18, 50)
                z1 = z - width
                # leave the cross streets open (20 m wide)
                hit = np.abs(CITY_CROSS_STREETS - (z + z1) / 2) < width / 2 + 10
                if not hit.any():
                    d = g.uniform(*depth)
                    h = np.exp(g.uniform(np.log(hmin), np.log(hmax)))
                    if g.random() < 0.04:
                        h *= 2.0                       # a few towers
                    xa, xb = sorted((side * x0, side * (x0 + d)))
                    meshes.append(box_mesh((xa, 0, z1), (xb, h, z), palette[g.integers(5)],
                                           bottom=False))
                z = z1 - g.uniform(2, 6)
    # the citadel closing the street's far end
    meshes.append(box_mesh((-60, 0, -CITY_LENGTH - 110), (60, 120, -CITY_LENGTH - 40),
                           (0.66, 0.62, 0.55), bottom=False))
    meshes.append(box_mesh((-15, 120, -CITY_LENGTH - 90), (15, 220, -CITY_LENGTH - 60),
                           (0.66, 0.62, 0.55), bottom=False))
    return meshes


def build_city(lights: int | None = None, seed: int = 0, distribution: str | None = None) -> Scene:
    """Street canyon reaching ~2 km (tree paper's EpicCitadel case): long view range."""
    n, rng, dist = _check_args("city", lights, seed, distribution, 4096, "geometry")
    meshes = _city_geometry()
    cx = CITY_CROSS_STREETS[1]
    cams = _cams([
        ((0, 5, 30), (0, 12, -500)),                          # street level, long view
        ((0, 60, 80), (0, 20, -1200)),                        # elevated, very long view
        ((6, 2, -300), (13, 6, -312)),                        # close to a facade
        ((-4, 3, cx), (200, 6, cx)),                          # down a cross street
        ((0, 4, -900), (0, 10, -1900)),                       # mid street towards the citadel
        ((0, 150, -CITY_LENGTH + 50), (0, 0, 0)),             # high, looking back, longest view
        ((0, 3, -CITY_LENGTH + 40), (0, 40, -CITY_LENGTH - 40)),  # at the citadel's foot
    ], near=0.5, far=3000.0)
    lo, hi = _aabb(meshes)
    lo[1] = 0.0
    ls = _distribute(n, dist, meshes, lo, hi, rng, (2.0, 40.0))
    return _finish("city", cams, meshes, ls)


def build_city_glass(lights: int | None = None, seed: int = 0,
                     distribution: str | None = None) -> Scene:
    """city with glass panes and particles over the street (scenes/glass.py): the same
    lights, cameras and opaque geometry, so city's figures stay city's."""
    from .glass import street_glass
    scene = build_city(lights, seed, distribution)
    scene.name = "city-glass"
    scene.meshes = scene.meshes + merge_meshes(street_glass())
    return scene


# ---------------------------------------------------------------------------------- arena
def _arena_geometry() -> list[Mesh]:
    g = np.random.default_rng(2002)
    ground, stone, metal, crate = (0.42, 0.40, 0.36), (0.62, 0.58, 0.52), (0.5, 0.52, 0.56), (0.6, 0.45, 0.3)
    m = [box_mesh((-100, -1, -100), (100, 0, 100), ground, bottom=False)]
    # perimeter walls
    m += [box_mesh((-102, 0, -102), (102, 12, -100), stone, bottom=False),
          box_mesh((-102, 0, 100), (102, 12, 102), stone, bottom=False),
          box_mesh((-102, 0, -100), (-100, 12, 100), stone, bottom=False),
          box_mesh((100, 0, -100), (102, 12, 100), stone, bottom=False)]
    # two bases (raised platforms with ramps) at the ends
    for s in (-1, 1):
        z0, z1 = sorted((s * 62, s * 92))
        m.append(box_mesh((-18, 0, z0), (18, 8, z1), stone, bottom=False))
        rz0, rz1 = sorted((s * 62, s * 40))
        m.append(ramp_mesh((-5, 0, rz0), (5, 8, rz1), "+z" if s > 0 else "-z", stone))
        sz0, sz1 = sorted((s * 78, s * 88))
        m.append(box_mesh((-8, 8, sz0), (8, 13, sz1), metal, bottom=False))
    # central platform with four ramps
    m.append(box_mesh((-12, 0, -12), (12, 5, 12), stone, bottom=False))
    m += [ramp_mesh((-4, 0, 12), (4, 5, 26), "-z", stone), ramp_mesh((-4, 0, -26), (4, 5, -12), "+z", stone),
          ramp_mesh((12, 0, -4), (26, 5, 4), "-x", stone), ramp_mesh((-26, 0, -4), (-12, 5, 4), "+x", stone)]
    # side towers with ramps and a bridge
    for s in (-1, 1):
        x0, x1 = sorted((s * 48, s * 66))
        m.append(box_mesh((x0, 0, -10), (x1, 10, 10), stone, bottom=False))
        m.append(ramp_mesh((x0, 0, 10), (x1, 10, 40), "-z", stone))
        bx0, bx1 = sorted((s * 12, s * 48))
        m.append(box_mesh((bx0, 4.5, -2), (bx1, 5, 2), metal))
    # pillars
    for x in (-80, -40, 40, 80):
        for z in (-45, 0, 45):
            m.append(box_mesh((x - 1, 0, z - 1), (x + 1, 14, z + 1), metal, bottom=False))
    # cover crates, fixed random layout
    for _ in range(24):
        c = g.uniform(-90, 90, 2)
        if abs(c[0]) < 30 and abs(c[1]) < 30:
            c[0] += 35 * np.sign(c[0] if c[0] != 0 else 1)
        sx, sz, h = g.uniform(2, 4), g.uniform(2, 4), g.uniform(1.5, 4)
        m.append(box_mesh((c[0] - sx, 0, c[1] - sz), (c[0] + sx, h, c[1] + sz), crate, bottom=False))
    return m


def build_arena(lights: int | None = None, seed: int = 0, distribution: str | None = None) -> Scene:
    """Mid-range level ~200 m across: platforms, ramps, pillars, open space (CTF-TitanPass)."""
    n, rng, dist = _check_args("arena", lights, seed, distribution, 4096, "uniform")
    meshes = _arena_geometry()
    cams = _cams([
        ((0, 18, 97), (0, 4, 0)),                 # above the south base, across the level
        ((0, 10, -70), (70, 2, 90)),              # on the north base, long diagonal
        ((-38, 2, -2), (-40, 6, 0)),              # close to a pillar (near view)
        ((0, 7, 0), (60, 8, 0)),                  # on the central platform towards a tower
        ((95, 25, 95), (-95, 0, -95)),            # corner, high, longest diagonal
        ((0, 1.8, 35), (0, 5, 0)),                # at the foot of a ramp
    ], near=0.25, far=600.0)
    lo, hi = _aabb(meshes)
    lo[1] = 0.0
    ls = _distribute(n, dist, meshes, lo, hi, rng, (1.0, 20.0))
    return _finish("arena", cams, meshes, ls)


# --------------------------------------------------------------------------------- hangar
HANGAR_LO = (-40.0, 0.0, -20.0)
HANGAR_HI = (40.0, 20.0, 20.0)


def _hangar_geometry() -> list[Mesh]:
    g = np.random.default_rng(3003)
    m = [box_mesh(HANGAR_LO, HANGAR_HI, (0.55, 0.55, 0.58), inward=True)]
    for x in np.arange(-30.0, 31.0, 12.0):
        for z in (-10.0, 10.0):
            m.append(box_mesh((x - 0.6, 0, z - 0.6), (x + 0.6, 20, z + 0.6), (0.4, 0.42, 0.45),
                              bottom=False))
    # catwalk along the north wall
    m.append(box_mesh((-40, 7.6, 15), (40, 8, 20), (0.45, 0.45, 0.48)))
    # crates, some stacked
    for _ in range(30):
        x, z = g.uniform(-36, 36), g.uniform(-17, 13)
        s = g.uniform(1.5, 3.0)
        m.append(box_mesh((x - s / 2, 0, z - s / 2), (x + s / 2, s, z + s / 2), (0.6, 0.47, 0.3),
                          bottom=False))
        if g.random() < 0.35:
            t = s * g.uniform(0.5, 0.9)
            m.append(box_mesh((x - t / 2, s, z - t / 2), (x + t / 2, s + t, z + t / 2),
                              (0.6, 0.47, 0.3), bottom=False))
    return m


def build_hangar(lights: int | None = None, seed: int = 0, distribution: str | None = None) -> Scene:
    """Closed hall 80x20x40 m filled with many large overlapping lights (Drobot's fire case)."""
    n, rng, dist = _check_args("hangar", lights, seed, distribution, 512, "uniform")
    meshes = _hangar_geometry()
    cams = _cams([
        ((-37, 3, 0), (37, 5, 0)),                # along the hall
        ((0, 8.8, 17.5), (5, 0, -10)),            # from the catwalk, looking down
        ((-20, 1.5, -15), (-15, 1, -12)),         # close to the crates
        ((38, 18, -18), (-38, 0, 18)),            # top corner, longest diagonal
        ((10, 2, 0), (-37, 4, 0)),                # looking back
    ], near=0.1, far=200.0)
    ls = _distribute(n, dist, meshes, np.array(HANGAR_LO), np.array(HANGAR_HI), rng, (4.0, 25.0))
    return _finish("hangar", cams, meshes, ls)


# A foggy hangar: the hall's lights seen through a homogeneous medium (scenes.model.Fog),
# a variant beside the hangar so that its figures and tests stay what they were.  The
# medium fills the hall's longest diagonal (~91 m); a forward-scattering g halos the lights.
HANGAR_FOG = Fog(density=0.02, albedo=(0.9, 0.9, 0.9), far=92.0, anisotropy=0.4)


def build_hangar_fog(lights: int | None = None, seed: int = 0, distribution: str | None = None) -> Scene:
    """The hangar in fog (HANGAR_FOG)."""
    scene = build_hangar(lights, seed, distribution)
    scene.name, scene.fog = "hangar-fog", HANGAR_FOG
    return scene


# -------------------------------------------------------------------------------- gallery
GALLERY_LO = (-30.0, 0.0, -12.0)
GALLERY_HI = (30.0, 8.0, 12.0)
GALLERY_POINTS = 6            # small point lights in the default scene


def _gallery_geometry():
    import trimesh
    wall, stone, art = (0.82, 0.80, 0.76), (0.7, 0.68, 0.64), (0.85, 0.82, 0.78)
    shell = [box_mesh(GALLERY_LO, GALLERY_HI, wall, inward=True)]
    parts = []
    for x in (-10.0, 10.0):                      # partitions with a 3 m x 4 m doorway
        parts += [box_mesh((x - 0.2, 0, -12), (x + 0.2, 8, -1.5), wall, bottom=False),
                  box_mesh((x - 0.2, 0, 1.5), (x + 0.2, 8, 12), wall, bottom=False),
                  box_mesh((x - 0.2, 4, -1.5), (x + 0.2, 8, 1.5), wall)]
    pedestals, sculptures, paintings = [], [], []
    sphere = trimesh.creation.icosphere(subdivisions=1)
    for room_x in (-20.0, 0.0, 20.0):
        for dx, dz in ((-4, -5), (4, -5), (-4, 5), (4, 5)):
            px, pz = room_x + dx, float(dz)
            pedestals.append(box_mesh((px - 0.5, 0, pz - 0.5), (px + 0.5, 1.2, pz + 0.5), stone,
                                      bottom=False))
            r = 0.45
            v = sphere.vertices * r + (px, 1.2 + r, pz)
            sculptures.append(Mesh(v.astype(np.float32), sphere.faces.astype(np.int32), art))
        # paintings on the long walls (thin boxes)
        for z, s in ((-12.0, 1), (12.0, -1)):
            for dx in (-5.0, 0.0, 5.0):
                za, zb = sorted((z, z + s * 0.06))
                paintings.append(box_mesh((room_x + dx - 1.2, 2.0, za), (room_x + dx + 1.2, 3.6, zb),
                                          (0.5, 0.35, 0.25)))
    return shell + parts, pedestals, sculptures, paintings


def build_gallery(lights: int | None = None, seed: int = 0, distribution: str | None = None) -> Scene:
    """Three rooms with pedestals, sculptures and paintings lit by large narrow spots
    (Mikkelsen's case) plus a few small point lights.  `lights=N`: N lights in all, 6 of them
    points (none when N < 12) and the rest spots; the default is 40 spots + 6 points."""
    n, rng, dist = _check_args("gallery", lights, seed, distribution,
                               40 + GALLERY_POINTS, "geometry")
    rooms, pedestals, sculptures, paintings = _gallery_geometry()
    meshes = rooms + pedestals + sculptures + paintings
    n_point = GALLERY_POINTS if n >= 2 * GALLERY_POINTS else 0
    n_spot = n - n_point
    lo, hi = np.array(GALLERY_LO), np.array(GALLERY_HI)
    ceiling = hi[1] - 0.4
    if dist == "geometry":
        # spots hang below the ceiling aimed at sculptures, paintings or the floor
        cat = rng.choice(3, size=n_spot, p=[0.5, 0.35, 0.15])
        targets = np.zeros((n_spot, 3))
        pos = np.zeros((n_spot, 3))
        for c, ms in enumerate((pedestals + sculptures, paintings, rooms[:1])):
            k = int(np.count_nonzero(cat == c))
            if k == 0:
                continue
            if c == 2:   # floor: uniform on the floor area
                t = np.column_stack([rng.uniform(lo[0] + 1, hi[0] - 1, k), np.zeros(k),
                                     rng.uniform(lo[2] + 1, hi[2] - 1, k)])
                nrm = np.tile([0.0, 1.0, 0.0], (k, 1))
            else:
                t, nrm = sample_on_geometry(k, ms, rng, offset=0.0)
            horiz = nrm * np.array([1.0, 0.0, 1.0])
            p = t + horiz * rng.uniform(2.0, 4.0, (k, 1)) + rng.uniform(-2, 2, (k, 3)) * [1, 0, 1]
            p[:, 1] = ceiling
            targets[cat == c], pos[cat == c] = t, p
        pos[:, 0] = np.clip(pos[:, 0], lo[0] + 0.5, hi[0] - 0.5)
        pos[:, 2] = np.clip(pos[:, 2], lo[2] + 0.5, hi[2] - 0.5)
        d = targets - pos
        bad = np.linalg.norm(d, axis=1) < 1e-3
        d[bad] = (0.0, -1.0, 0.0)
    else:
        pos = lo + rng.random((n_spot, 3)) * (hi - lo) * [1, 0, 1]
        pos[:, 1] = rng.uniform(4.0, ceiling, n_spot)
        # mostly down: tilt up to 45 degrees
        tilt = np.radians(rng.uniform(0, 45, n_spot))
        az = rng.uniform(0, 2 * np.pi, n_spot)
        d = np.column_stack([np.sin(tilt) * np.cos(az), -np.cos(tilt), np.sin(tilt) * np.sin(az)])
    spots = spot_lights(pos, d, rng, (10.0, 30.0), outer_deg_range=(10.0, 30.0),
                        inner_ratio_range=(0.6, 0.9))
    points = _distribute(n_point, dist, meshes, lo, hi, rng, (0.5, 3.0))
    ls = np.concatenate([spots, points]) if n else make_lights(0)
    cams = _cams([
        ((-28, 1.7, 0), (28, 1.7, 0)),            # through both doorways, longest view
        ((-18, 1.6, -2.5), (-16, 1.6, -5)),       # close to a sculpture
        ((8, 5, 10), (-8, 1, -10)),               # corner of the middle room
        ((3, 2.5, 0), (3, 2.8, -12)),             # at the paintings
        ((28, 7, 11), (-28, 0, -11)),             # high corner, looking back through the rooms
    ], near=0.1, far=100.0)
    return _finish("gallery", cams, meshes, ls)


CORRIDOR_LO = (-4.0, 0.0, -120.0)
CORRIDOR_HI = (4.0, 4.0, 8.0)
WINDOW_EVERY = 6.0              # a window in the left wall every 6 m
WINDOW = (2.0, 2.2, 1.0)        # its width (along z), height, sill height (m)


def _with(mesh: Mesh, **material) -> Mesh:
    for k, v in material.items():
        setattr(mesh, k, v)
    return mesh


def _corridor_geometry() -> list[Mesh]:
    """A long corridor: floor, ceiling, a right wall with piers, a left wall with windows
    (the openings are gaps between wall pieces) and a few crates."""
    lo, hi = np.array(CORRIDOR_LO), np.array(CORRIDOR_HI)
    wall, floor, crate = (0.8, 0.78, 0.74), (0.55, 0.55, 0.58), (0.6, 0.45, 0.3)
    ms = [_with(box_mesh((lo[0], -0.2, lo[2]), (hi[0], 0.0, hi[2]), floor), roughness=0.25),
          box_mesh((lo[0], hi[1], lo[2]), (hi[0], hi[1] + 0.2, hi[2]), wall),
          box_mesh((hi[0], 0.0, lo[2]), (hi[0] + 0.3, hi[1], hi[2]), wall),
          box_mesh((lo[0], 0.0, lo[2] - 0.3), (hi[0], hi[1], lo[2]), wall),
          box_mesh((lo[0], 0.0, hi[2]), (hi[0], hi[1], hi[2] + 0.3), wall)]
    w, h, sill = WINDOW
    z = hi[2]
    for zc in np.arange(hi[2] - WINDOW_EVERY / 2, lo[2], -WINDOW_EVERY):
        x0, x1 = lo[0] - 0.3, lo[0]
        ms.append(box_mesh((x0, 0.0, zc + w / 2), (x1, hi[1], z), wall))          # wall piece
        ms.append(box_mesh((x0, 0.0, zc - w / 2), (x1, sill, zc + w / 2), wall))  # below
        ms.append(box_mesh((x0, sill + h, zc - w / 2), (x1, hi[1], zc + w / 2), wall))
        z = zc - w / 2
    ms.append(box_mesh((lo[0] - 0.3, 0.0, lo[2]), (lo[0], hi[1], z), wall))
    for zc in np.arange(-10.0, lo[2], -17.0):                                    # piers, crates
        ms.append(box_mesh((hi[0] - 0.6, 0.0, zc - 0.4), (hi[0], hi[1], zc + 0.4), wall, bottom=False))
        ms.append(_with(box_mesh((-1.5, 0.0, zc - 6.0), (-0.3, 1.0, zc - 4.8), (0.9, 0.7, 0.45),
                                 bottom=False), roughness=0.4, metallic=1.0))     # brass crates
    return ms


def build_corridor(lights: int | None = None, seed: int = 0, distribution: str | None = None) -> Scene:
    """All four light shapes: tube lights (capsules) along the ceiling, light
    shafts (boxes) in the windows of the left wall, spots washing the right wall, and point
    lights (uniform in the corridor or on its geometry).  `lights=N`: 40% capsules, 20%
    boxes, 20% spots, the rest points; default 512."""
    n, rng, dist = _check_args("corridor", lights, seed, distribution, 512, "uniform")
    meshes = _corridor_geometry()
    lo, hi = np.array(CORRIDOR_LO), np.array(CORRIDOR_HI)
    n_cap, n_box, n_spot = int(0.4 * n), int(0.2 * n), int(0.2 * n)
    n_point = n - n_cap - n_box - n_spot
    caps = make_lights(n_cap)                   # tubes below the ceiling, along the corridor
    caps["type"] = LIGHT_CAPSULE
    caps["position"] = np.column_stack([rng.uniform(-2.5, 2.5, n_cap), np.full(n_cap, hi[1] - 0.3),
                                        rng.uniform(lo[2], hi[2], n_cap)])
    caps["direction"] = (0.0, 0.0, 1.0)
    caps["length"] = rng.uniform(1.0, 3.0, n_cap)
    _fill_common(caps, sample_radii(n_cap, rng, (1.0, 6.0)), rng)
    boxes = make_lights(n_box)                  # shafts through the windows, into the corridor
    boxes["type"] = LIGHT_BOX
    windows = np.arange(hi[2] - WINDOW_EVERY / 2, lo[2], -WINDOW_EVERY)
    zc = rng.choice(windows, n_box) + rng.uniform(-0.3, 0.3, n_box)
    depth = rng.uniform(1.5, 4.0, n_box)        # how far the shaft reaches into the room
    tilt = np.radians(rng.uniform(-35.0, -10.0, n_box))
    d = np.column_stack([np.cos(tilt), np.sin(tilt), np.zeros(n_box)])
    boxes["direction"] = d
    boxes["up"] = (0.0, 0.0, 1.0)
    boxes["extent"] = np.column_stack([rng.uniform(0.6, 1.0, n_box), np.full(n_box, WINDOW[1] / 2), depth])
    boxes["position"] = np.column_stack([np.full(n_box, lo[0]), np.full(n_box, WINDOW[2] + WINDOW[1] / 2),
                                         zc]) + d * depth[:, None]
    _fill_common(boxes, sample_radii(n_box, rng, (1.0, 3.0)), rng)
    boxes["intensity"] = rng.uniform(0.3, 1.0, n_box)
    pos = np.column_stack([np.full(n_spot, lo[0] + 0.5), rng.uniform(2.5, 3.8, n_spot),
                           rng.uniform(lo[2], hi[2], n_spot)])
    aim = np.column_stack([np.full(n_spot, hi[0]), rng.uniform(0.0, 2.0, n_spot), pos[:, 2] + rng.uniform(-3, 3, n_spot)])
    spots = spot_lights(pos, aim - pos, rng, (4.0, 12.0), outer_deg_range=(15.0, 40.0))
    points = _distribute(n_point, dist, meshes, lo, hi, rng, (0.3, 2.0))
    cams = _cams([((0.0, 1.7, 6.0), (0.0, 1.6, -40.0)),          # down the corridor
                  ((2.5, 2.0, -30.0), (-4.0, 1.5, -34.0)),        # at the windows' shafts
                  ((-1.0, 3.0, -70.0), (1.0, 1.0, -100.0)),       # under the tubes, looking down
                  ((3.0, 1.2, -90.0), (-4.0, 2.5, -92.0)),        # up at a window
                  ((0.0, 1.7, -115.0), (0.0, 1.7, 0.0))],         # back along the corridor
                 near=0.1, far=200.0)
    return _finish("corridor", cams, meshes, np.concatenate([caps, boxes, spots, points]))


# ----------------------------------------------------------------------------- contention
CONTENTION_LO = (-24.0, 0.0, -16.0)
CONTENTION_HI = (24.0, 10.0, 16.0)
CONTENTION_BIG = ((-12.0, 5.0, 0.0), (0.0, 6.0, -4.0), (12.0, 5.0, 4.0))   # the full-screen lights
CONTENTION_BIG_RADIUS = 64.0      # past the hall's 58.5 m diagonal: every visible point, any camera
CONTENTION_BIG_COLOR = ((1.0, 0.82, 0.62), (1.0, 1.0, 1.0), (0.62, 0.78, 1.0))


def _contention_geometry() -> list[Mesh]:
    wall, stone = (0.6, 0.6, 0.62), (0.5, 0.48, 0.45)
    m = [box_mesh(CONTENTION_LO, CONTENTION_HI, wall, inward=True)]
    for x in (-16.0, 0.0, 16.0):                                   # two rows of pillars
        for z in (-8.0, 8.0):
            m.append(box_mesh((x - 0.8, 0, z - 0.8), (x + 0.8, 10, z + 0.8), stone, bottom=False))
    for x, z, h in ((-8, -3, 1.5), (8, 5, 2.5), (-20, 12, 1.0), (20, -12, 3.0)):   # a few crates
        m.append(box_mesh((x - 1.5, 0, z - 1.5), (x + 1.5, h, z + 1.5), (0.6, 0.47, 0.3), bottom=False))
    return m


def build_contention(lights: int | None = None, seed: int = 0, distribution: str | None = None) -> Scene:
    """Drobot 2017's atomic contention case ("3 x full screen lights", the tile rasterizer
    table): a closed hall 48 x 10 x 32 m, three point lights whose spheres hold the whole
    hall (every camera inside them: every pixel of every frame is lit by all three, so each
    of a tile's pixels issues its atomic on the same word), plus a field of small point
    lights (radius 0.5-2 m, uniform in the hall or on its geometry).  `lights=N`: N lights
    in all, the first min(N, 3) the full-screen ones; default 256 (the slides' cluster case)."""
    n, rng, dist = _check_args("contention", lights, seed, distribution, 256, "uniform")
    meshes = _contention_geometry()
    k = min(n, len(CONTENTION_BIG))
    big = make_lights(k)
    big["position"] = np.asarray(CONTENTION_BIG, np.float64)[:k]
    big["radius"] = CONTENTION_BIG_RADIUS
    big["color"] = np.asarray(CONTENTION_BIG_COLOR, np.float64)[:k]
    big["intensity"] = 8.0           # 0.08 at 10 m: under half a small light's at half a metre
    small = _distribute(n - k, dist, meshes, np.array(CONTENTION_LO), np.array(CONTENTION_HI),
                        rng, (0.5, 2.0))
    cams = _cams([
        ((-22, 2, 0), (22, 3, 0)),                # along the hall
        ((0, 9, 15), (0, 0, -10)),                # high, looking down
        ((22, 1.7, -14), (-22, 2, 14)),           # corner, longest diagonal
        ((-10, 1.7, 4), (-16, 1.5, 8)),           # close to a pillar
        ((0, 4, -15), (0, 3, 15)),                # across the hall
    ], near=0.1, far=200.0)
    return _finish("contention", cams, meshes, np.concatenate([big, small]))


# --------------------------------------------------------------------------------- stress
STRESS_RADIUS = 50.0              # Bevy's many_lights: RADIUS
STRESS_FREQUENCY = 15             # geodesic sphere: 20 * 15^2 = 4,500 triangles (Bevy's
                                  # icosphere of 9 subdivisions would be 5.2 million)
STRESS_LIGHTS = 100_000           # Bevy's N_LIGHTS
STRESS_RANGE = 0.3                # Bevy's LIGHT_RADIUS, at STRESS_LIGHTS lights and more
STRESS_MAX_RANGE = STRESS_RADIUS / 4
STRESS_OFFSET = 0.05              # lights sit this far off the mesh, alternately in and out
FIBONACCI_EPSILON = 0.36          # Bevy's offset of the lattice (best mean nearest-neighbour distance)
STRESS_CUBE = 5.0                 # Bevy's reference cube at the top of the sphere, half out of it


def stress_range(n: int) -> float:
    """Every light's range: Bevy's 0.3 m from 100,000 lights up (each point of the sphere is
    then in reach of n r^2 / (4 R^2) lights: 0.9 at 100,000, 9 at 1,000,000); below that
    count the range grows as 1 / sqrt(n), keeping 0.9 lights a point (capped at R / 4), so a
    small draw lights as much of the sphere."""
    if n >= STRESS_LIGHTS:
        return STRESS_RANGE
    return min(STRESS_RANGE * float(np.sqrt(STRESS_LIGHTS / max(n, 1))), STRESS_MAX_RANGE)


def fibonacci_sphere(n: int) -> np.ndarray:
    """(n, 3) float64 unit vectors: Bevy's Fibonacci spiral (golden-ratio azimuth, offset
    polar steps), in float64 as there."""
    i = np.arange(n, dtype=np.float64)
    theta = 2.0 * np.pi * i / (0.5 * (1.0 + np.sqrt(5.0)))
    phi = np.arccos(1.0 - 2.0 * (i + FIBONACCI_EPSILON) / (n - 1.0 + 2.0 * FIBONACCI_EPSILON))
    return np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])


def geodesic_sphere(radius: float, frequency: int) -> Mesh:
    """A class I geodesic sphere: each icosahedron face cut into frequency^2 triangles, the
    points pushed out to `radius`; shared vertices merged (watertight), faces wound outwards."""
    import trimesh
    ico = trimesh.creation.icosahedron()
    f = int(frequency)
    i, j = np.nonzero(np.add.outer(np.arange(f + 1), np.arange(f + 1)) <= f)
    grid = {(a, b): k for k, (a, b) in enumerate(zip(i.tolist(), j.tolist()))}
    tris = [(grid[a, b], grid[a + 1, b], grid[a, b + 1]) for a, b in grid if a + b < f]
    tris += [(grid[a + 1, b], grid[a + 1, b + 1], grid[a, b + 1]) for a, b in grid if a + b < f - 1]
    tris = np.array(tris)
    A, B, C = (ico.vertices[ico.faces[:, k]] for k in range(3))          # (20, 3) each
    pts = (A[:, None] + (B - A)[:, None] * (i / f)[None, :, None]
           + (C - A)[:, None] * (j / f)[None, :, None])                  # (20, P, 3)
    pts = pts / np.linalg.norm(pts, axis=2, keepdims=True) * radius
    faces = (tris[None] + len(i) * np.arange(20)[:, None, None]).reshape(-1, 3)
    verts, inverse = np.unique(np.round(pts.reshape(-1, 3), 6), axis=0, return_inverse=True)
    return Mesh(verts.astype(np.float32), inverse.reshape(-1)[faces].astype(np.int32), (1.0, 1.0, 1.0))


def _random_rotation(rng) -> np.ndarray:
    """A uniformly random 3x3 rotation (a normalised Gaussian quaternion)."""
    w, x, y, z = (q := rng.normal(size=4)) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _hue_colors(n: int, rng) -> np.ndarray:
    """Bevy's colours: a random hue at full saturation and lightness 0.5, (n, 3) in [0, 1]."""
    h = rng.uniform(0.0, 6.0, n)             # hue in sixths of the circle
    return np.clip(np.column_stack([np.abs(h - 3.0) - 1.0, 2.0 - np.abs(h - 2.0),
                                    2.0 - np.abs(h - 4.0)]), 0.0, 1.0)


def inscribed_radius(mesh: Mesh) -> float:
    """The distance from the origin to the nearest plane of a face of `mesh`."""
    t = mesh.vertices.astype(np.float64)[mesh.faces]
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    return float((np.abs(np.einsum("ij,ij->i", t[:, 0], n)) / np.linalg.norm(n, axis=1)).min())


def build_stress(lights: int | None = None, seed: int = 0, distribution: str | None = None) -> Scene:
    """Bevy's `many_lights` stress test: point lights of small range on a sphere of radius
    50 m, lighting that sphere's mesh (a geodesic sphere, two-sided like every surface here),
    seen from inside (the first four cameras) and from outside (the last three); the path
    crosses the wall between them.  Light 2k sits STRESS_OFFSET inside the mesh (it lights
    the inner face), light 2k+1 as far outside (the outer face).  `uniform` (default): Bevy's
    Fibonacci lattice, turned by a random rotation of the seed, inside the faces' planes or
    outside the vertices; `geometry`: area-weighted random points of the mesh's triangles,
    pushed along the face normal.  Every light's range is `stress_range(n)` (0.3 m, Bevy's,
    from 100,000 lights up), over twice its distance to the mesh (at most 0.12 m), so every
    light lights it.  `lights=N`, default 100,000 (up to MAX_LIGHTS)."""
    n, rng, dist = _check_args("stress", lights, seed, distribution, STRESS_LIGHTS, "uniform")
    sphere = geodesic_sphere(STRESS_RADIUS, STRESS_FREQUENCY)
    c = STRESS_CUBE / 2
    cube = box_mesh((-c, STRESS_RADIUS - c, -c), (c, STRESS_RADIUS + c, c), (1.0, 0.75, 0.8))
    side = np.where(np.arange(n) % 2 == 0, -1.0, 1.0)              # in, out, in, out, ...
    if dist == "uniform":
        shell = np.where(side < 0, inscribed_radius(sphere) - STRESS_OFFSET,
                         STRESS_RADIUS + STRESS_OFFSET)
        pos = fibonacci_sphere(n) @ _random_rotation(rng).T * shell[:, None]
    else:
        p, nrm = sample_on_geometry(n, [sphere], rng, offset=0.0)
        nrm *= np.sign(np.einsum("ij,ij->i", p, nrm))[:, None]    # outwards
        pos = p + (side * STRESS_OFFSET)[:, None] * nrm
    ls = make_lights(n)
    ls["position"] = pos
    ls["radius"] = stress_range(n)
    ls["color"] = _hue_colors(n, rng)
    r = STRESS_RADIUS
    cams = _cams([
        ((0, 0, 0), (0, 0, -r)),                       # inside, at the centre: the far wall
        ((0, 0, 0), (5, r - 2, 1)),                    # inside, up at the cube
        ((0, -0.8 * r, 0.4 * r), (0, -0.8 * r, -r)),   # inside, near the wall, grazing along it
        ((0, 0.1 * r, -0.6 * r), (0, 0, -r)),          # inside, 20 m from the wall
        ((0, 0.6 * r, 2.8 * r), (0, 0, 0)),            # outside, the whole sphere
        ((1.4 * r, 0.2 * r, 0.2 * r), (0, 0, 0)),      # outside, 20 m above the surface
        ((1.2 * r, 0.9 * r, 1.2 * r), (0, r, 0)),      # outside, at the cube
    ], near=0.1, far=1000.0)
    return _finish("stress", cams, [sphere, cube], ls)

BUILTIN_SCENES = {
    "city": build_city,
    "arena": build_arena,
    "hangar": build_hangar,
    "gallery": build_gallery,
    "corridor": build_corridor,
    "contention": build_contention,
    "stress": build_stress,
    "city-glass": build_city_glass,
}

# Variants of the builtin scenes: loaded by name like them (load_scene, capture --list), but
# not among the scenes every test and study iterates (their figures stay the same).
BUILTIN_VARIANTS = {
    "hangar-fog": build_hangar_fog,
}
