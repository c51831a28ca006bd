"""The engines' view-level light caps (issue 21 item 2): which of a frame's visible lights
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

The per-tile caps (HDRP FPTL 24 / 63 lights a 16x16 tile and category) act inside a tile's
list build and are not here.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT

NONE = "none"
SCENE_ORDER, NEAREST = "scene", "nearest"
ALL_TYPES = (LIGHT_POINT, LIGHT_SPOT, LIGHT_CAPSULE, LIGHT_BOX)


@dataclass(frozen=True)
class Policy:
    name: str
    budgets: tuple[tuple[tuple[int, ...], int], ...]   # ((light types, most kept), ...)
    order: str                                          # SCENE_ORDER | NEAREST
    source: str                                         # where the engine does it

    def __post_init__(self) -> None:
        if self.order not in (SCENE_ORDER, NEAREST) or any(n < 1 for _, n in self.budgets):
            raise ValueError(f"cap policy {self.name}: order {self.order!r}, budgets {self.budgets}")


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
)}
NAMES = tuple(POLICIES)


def camera_distance(positions: np.ndarray, view_from_world: np.ndarray) -> np.ndarray:
    """(N,) float64 distance from the eye to each world position (N, 3): the length of the
    position in view space (the view transform is rigid)."""
    m = np.asarray(view_from_world, np.float64)
    view = np.asarray(positions, np.float64) @ m[:3, :3].T + m[:3, 3]
    return np.sqrt((view * view).sum(1))


def keep(policy: str, ids: np.ndarray, types: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """(N,) bool: which of the visible lights (scene ids, types, camera distances, in any
    order) `policy` keeps."""
    p = POLICIES[policy]
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
    if policy == NONE or not len(ids):
        return keyed, depth, np.zeros(0, np.uint32)
    rows = scene_lights[ids]
    kept = keep(policy, ids, rows["type"], camera_distance(rows["position"], view_from_world))
    return keyed[kept], depth[kept], np.sort(ids[~kept]).astype(np.uint32)


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


__all__ = ["NONE", "NAMES", "POLICIES", "Policy", "keep", "apply", "without", "camera_distance"]
