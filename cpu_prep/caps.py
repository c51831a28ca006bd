"""The engines' view-level light caps: which of a frame's visible lights
an engine would keep, numpy in, numpy out.  docs/research/accuracy_policies.md has the
sources, read file by file; each policy below names the file and function it follows.

    visible lights (the cull's, scene order)  --keep()-->  the kept ones, the rest dropped
    from every structure and never shaded (the lab's default, "none", drops nothing)

A policy is a list of budgets, each over a group of light types, and an order that says
which lights of a group over its budget go first:

    "scene"    the first in scene order are kept (the lab's deterministic stand-in for an
               engine's cull or job order; each policy says which)
    "nearest"  the nearest to the camera are kept: Euclidean distance from the eye to the
               light's position (its centre; a spot's apex), ties broken by scene id

    "hdrp-key" HDRP's light sort key (per_tile policies): the lowest keys are kept

A per_tile policy (HDRP FPTL: 24 or 63 lights of each category in a 16x16 tile's fine-pruned
list) drops nothing from the view: it acts inside fptl's per-tile list build
(app/techniques/fptl/, app/techniques/fptl/fptl_lists.comp), and tile_keep() here is its CPU statement,
from which the exactness check computes the lights each tile must keep (app/tile_caps.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT

NONE = "none"
SCENE_ORDER, NEAREST, HDRP_KEY = "scene", "nearest", "hdrp-key"
ALL_TYPES = (LIGHT_POINT, LIGHT_SPOT, LIGHT_CAPSULE, LIGHT_BOX)


@dataclass(frozen=True)
class Policy:
    name: str
    budgets: tuple[tuple[tuple[int, ...], int], ...]   # ((light types, most kept), ...)
    order: str                                          # SCENE_ORDER | NEAREST | HDRP_KEY
    source: str                                         # where the engine does it
    per_tile: bool = False                              # budgets per 16x16 tile (fptl only)

    def __post_init__(self) -> None:
        if self.order not in (SCENE_ORDER, NEAREST, HDRP_KEY) or any(n < 1 for _, n in self.budgets) \
                or (self.order == HDRP_KEY) != self.per_tile:
            raise ValueError(f"cap policy {self.name}: order {self.order!r}, budgets {self.budgets}")


# HDRP's classification of the lab's shapes (HDRenderPipeline.EvaluateGPULightType, LightLoop.cs):
# (LightCategory, GPULightType, LightVolumeType) with the enums of LightLoop.cs.hlsl and
# LightDefinitions.cs: Punctual 0 / Area 1; Point 1, Spot 2, ProjectorBox 4, Tube 5; Cone 0,
# Sphere 1, Box 2.  A point is a Point (sphere volume), a spot a cone Spot, a box HDRP's
# box-shaped spot (ProjectorBox, box volume), a capsule HDRP's tube area light (box volume).
HDRP_CLASS = {LIGHT_POINT: (0, 1, 1), LIGHT_SPOT: (0, 2, 0), LIGHT_BOX: (0, 4, 2),
              LIGHT_CAPSULE: (1, 5, 2)}
HDRP_PUNCTUAL, HDRP_AREA = (LIGHT_POINT, LIGHT_SPOT, LIGHT_BOX), (LIGHT_CAPSULE,)
assert {HDRP_CLASS[t][0] for t in HDRP_PUNCTUAL} == {0} and HDRP_CLASS[LIGHT_CAPSULE][0] == 1
_HDRP_CLASS_KEY = np.array([(c << 10 | g << 5 | v) for c, g, v in
                            (HDRP_CLASS[t] for t in range(len(ALL_TYPES)))], np.uint64)


def hdrp_sort_key(types: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """(N,) uint64 keys ordered as HDRP's PackLightSortKey (HDGpuLightsBuilder.cs):
    isDirectional << 31 | isOffscreen << 30 | category << 26 | GPU light type << 21 |
    volume type << 16 | visibleLights index.  The lab has no directional light and culls to
    the frustum (never off screen), so those bits are constant; the index is the scene id
    (the lab's stand-in for Unity's cull order), kept whole in the low 32 bits where HDRP
    packs 16, so that no two lights share a key past 65,536."""
    cls = _HDRP_CLASS_KEY[np.asarray(types, np.intp)]
    return cls << np.uint64(32) | np.asarray(ids, np.uint64)


def _fptl(n: int, era: str) -> Policy:
    # HDRP FPTL (lightlistbuild.compute, TileLightListGen): the 16x16 tile's fine-pruned list,
    # sorted by light index (SORTLIST: the lights are in sort-key order), is written per
    # category with nrLightsFinalClamped = min(count, SHADEROPTIONS_FPTLMAX_LIGHT_COUNT): the
    # lowest sort keys of each category are kept, the rest silently dropped.  Env and decal
    # categories have no lab counterpart.  The coarse list's own cap (64,
    # LIGHT_LIST_MAX_COARSE_ENTRIES, atomic arrival order) is not modelled: the lab's coarse
    # test is its own (docs/research/accuracy_policies.md 1.1).
    return Policy(f"hdrp-fptl-{n}", ((HDRP_PUNCTUAL, n), (HDRP_AREA, n)), HDRP_KEY,
                  f"HDRP FPTL {n} lights a tile and category, {era} (lightlistbuild.compute)",
                  per_tile=True)


def _urp(n: int, tier: str) -> Policy:
    # Unity URP: UniversalRenderPipeline.maxVisibleAdditionalLights (UniversalRenderPipeline.cs;
    # the numbers in universal-config ShaderConfig.cs, k_MaxVisibleLightCount*), enforced by
    # UniversalRenderer.SetupCullingParameters as cullingParameters.maximumVisibleLights.  Its
    # order is Unity's native cull, documented for ScriptableCullingParameters.
    # maximumVisibleLights: directional lights first (the lab has none), "then the remaining
    # light types are sorted by distance to the camera", so the farthest go.  Unverified
    # (native code): distance to the position or to the bounds, and the tie order; the lab
    # takes the position and scene id.
    return Policy(f"urp-{n}", ((ALL_TYPES, n),), NEAREST,
                  f"URP maxVisibleAdditionalLights, {tier} (UniversalRenderPipeline.cs)")


POLICIES: dict[str, Policy] = {p.name: p for p in (
    Policy(NONE, (), SCENE_ORDER, "the lab: every visible light, never dropped"),
    # Unity HDRP: GlobalLightLoopSettings.NewDefault() (maxPunctualLightsOnScreen = 512,
    # maxAreaLightsOnScreen = 64), applied in HDProcessedVisibleLightsBuilder.Jobs.cs,
    # ProcessVisibleLightJob.Execute -> IncrementLightCounterAndTestLimit: an Interlocked
    # counter per category in a parallel job over visibleLights, so the lights past the cap
    # are those whose job iteration came late: a thread race.  Deterministic stand-in: the
    # first in scene order are kept (what a sequential walk over visibleLights gives).
    # Categories: point, spot and box (HDRP's box-shaped spot, GPULightType.ProjectorBox) are
    # punctual; the capsule is HDRP's tube light, an area light.
    Policy("hdrp-view", (((LIGHT_POINT, LIGHT_SPOT, LIGHT_BOX), 512), ((LIGHT_CAPSULE,), 64)),
           SCENE_ORDER, "HDRP maxPunctualLightsOnScreen 512 / maxAreaLightsOnScreen 64 "
                        "(HDProcessedVisibleLightsBuilder.Jobs.cs)"),
    # Godot 4 Forward+: rendering/limits/cluster_builder/max_clustered_elements = 512
    # (rendering_server.cpp), LightStorage::update_light_buffers (light_storage.cpp): its loop
    # over the scene cull's lights does `if (omni_light_count >= max_lights) continue;` (and
    # the same for spots) before any distance is computed, and sorts only the survivors by
    # distance.  So the first 512 of each type in cull order are kept; the lab's stand-in for
    # the cull order is scene order.  ClusterBuilderRD::add_light / add_box give each element
    # type its own budget; the lab's capsules and boxes (no Godot type) get one each too.
    Policy("godot-512", tuple(((t,), 512) for t in ALL_TYPES), SCENE_ORDER,
           "Godot max_clustered_elements 512 per element type (light_storage.cpp "
           "update_light_buffers)"),
    # Filament: CONFIG_MAX_LIGHT_COUNT = 256 positional lights (EngineEnums.h);
    # FView::prepareVisibleLights (View.cpp): computeLightCameraDistances (the eye to the
    # light's centre, radius ignored), std::sort ascending, then resize to the cap: the
    # farthest go.  std::sort is not stable (ties unspecified): the lab breaks them by scene id.
    Policy("filament-256", ((ALL_TYPES, 256),), NEAREST,
           "Filament CONFIG_MAX_LIGHT_COUNT 256 (View.cpp prepareVisibleLights)"),
    _urp(256, "desktop"),
    _urp(32, "mobile, OpenGL Core, GLES3"),
    _urp(16, "low-end mobile, GLES <= 3.0"),
    _fptl(24, "LIGHT_LIST_MAX_PRUNED_ENTRIES before HDRP 13.1"),
    _fptl(63, "ShaderOptions.FPTLMaxLightCount = FPTLMaxLightSizes.High since HDRP 13.1"),
)}
NAMES = tuple(POLICIES)
TILE_NAMES = tuple(n for n, p in POLICIES.items() if p.per_tile)


def per_tile(policy: str) -> bool:
    """Whether `policy` caps each tile's list (fptl's build) rather than the view's lights."""
    return POLICIES[policy].per_tile


def camera_distance(positions: np.ndarray, view_from_world: np.ndarray) -> np.ndarray:
    """(N,) float64 distance from the eye to each world position (N, 3): the length of the
    position in view space (the view transform is rigid)."""
    m = np.asarray(view_from_world, np.float64)
    view = np.asarray(positions, np.float64) @ m[:3, :3].T + m[:3, 3]
    return np.sqrt((view * view).sum(1))


def keep(policy: str, ids: np.ndarray, types: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """(N,) bool: which of the visible lights (scene ids, types, camera distances, in any
    order) `policy` keeps.  A per-tile policy keeps every light of the view."""
    p = POLICIES[policy]
    if p.per_tile:
        return np.ones(len(ids), bool)
    ids = np.asarray(ids, np.int64)
    out = np.ones(len(ids), bool)
    for group, budget in p.budgets:
        members = np.nonzero(np.isin(types, group))[0]
        if len(members) <= budget:
            continue
        if p.order == SCENE_ORDER:
            ranked = members[np.argsort(ids[members], kind="stable")]
        else:
            ranked = members[np.lexsort((ids[members], np.asarray(distance)[members]))]
        out[ranked[budget:]] = False
    return out


def apply(policy: str, scene_lights: np.ndarray, view_from_world: np.ndarray,
          keyed: np.ndarray, depth: np.ndarray):
    """The cull's visible lights (keyed: sort key << 32 | scene id, depth) under `policy`:
    (keyed, depth) of the kept ones, in their order, and the dropped scene ids (uint32,
    ascending)."""
    ids = (np.asarray(keyed) & np.uint64(0xFFFFFFFF)).astype(np.int64)
    if policy == NONE or per_tile(policy) or not len(ids):
        return keyed, depth, np.zeros(0, np.uint32)
    rows = scene_lights[ids]
    kept = keep(policy, ids, rows["type"], camera_distance(rows["position"], view_from_world))
    return keyed[kept], depth[kept], np.sort(ids[~kept]).astype(np.uint32)


def tile_keep(policy: str, tiles: np.ndarray, types: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """(N,) bool over a frame's (tile, light) list entries, each entry once: which ones the
    per-tile `policy` keeps, the `budget` lowest sort keys (hdrp_sort_key) of each budget's
    group in each tile."""
    p = POLICIES[policy]
    if not p.per_tile:
        raise ValueError(f"cap policy {policy} is not per tile")
    tiles, types = np.asarray(tiles, np.int64), np.asarray(types, np.intp)
    group = np.full(len(types), -1, np.int64)
    for g, (members, _) in enumerate(p.budgets):
        group[np.isin(types, members)] = g
    if (group < 0).any():
        raise ValueError(f"cap policy {policy}: a light type outside its budgets")
    budget = np.array([n for _, n in p.budgets], np.int64)
    order = np.lexsort((hdrp_sort_key(types, ids), group, tiles))
    t, g = tiles[order], group[order]
    k = np.arange(len(order))
    start = np.ones(len(order), bool)
    start[1:] = (t[1:] != t[:-1]) | (g[1:] != g[:-1])
    rank = k - np.maximum.accumulate(np.where(start, k, 0))
    out = np.empty(len(order), bool)
    out[order] = rank < budget[g]
    return out


def without(scene_lights: np.ndarray, ids: np.ndarray, view_from_world: np.ndarray,
            copy: bool = True) -> np.ndarray:
    """A copy of the scene's lights (copy=False: the array itself, which the caller owns) in
    which the lights `ids` reach nothing and are culled (no volume, behind the eye), every
    id unchanged: the frame a capped technique is exact against (app.exactness)."""
    out = scene_lights.copy() if copy else scene_lights
    ids = np.asarray(ids, np.int64)
    world_from_view = np.linalg.inv(np.asarray(view_from_world, np.float64))
    behind = world_from_view @ np.array([0.0, 0.0, 1.0e3, 1.0])   # view -z is forward
    out["position"][ids] = behind[:3]
    for name in ("radius", "length", "intensity"):
        out[name][ids] = 0.0
    out["extent"][ids] = 0.0
    return out


__all__ = ["NONE", "NAMES", "TILE_NAMES", "POLICIES", "Policy", "per_tile", "keep", "apply", "tile_keep",
           "hdrp_sort_key", "HDRP_CLASS", "without", "camera_distance"]
