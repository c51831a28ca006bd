"""cpu_prep.caps: each engine's view-level light cap keeps the lights that engine keeps, in
its drop order (docs/research/accuracy_policies.md), and `none` keeps every light."""
import numpy as np
import pytest

from cpu_prep import caps, frame as cpuframe, lights as lightsmod
from cpu_prep.camera import frame_camera
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT, Camera, make_lights


def _shuffled(rng, n):
    """Scene ids 0..n-1 in a random order (keep() takes the visible lights in any order)."""
    return rng.permutation(n)


def test_none_keeps_every_light(rng):
    ids = _shuffled(rng, 3000)
    assert caps.keep(caps.NONE, ids, np.zeros(3000, np.uint8), rng.random(3000)).all()


@pytest.mark.parametrize("policy, cap", [("filament-256", 256), ("urp-256", 256), ("urp-32", 32),
                                         ("urp-16", 16)])
def test_nearest_policies_keep_the_nearest_ties_by_scene_id(rng, policy, cap):
    n = 300
    ids = _shuffled(rng, n)
    types = rng.integers(0, 4, n).astype(np.uint8)           # one budget over every type
    dist = np.round(rng.uniform(1, 50, n), 0)                # many ties
    kept = caps.keep(policy, ids, types, dist)
    assert kept.sum() == cap
    # the kept ones are the first `cap` by (distance, scene id): the farthest went
    rank = np.lexsort((ids, dist))
    assert set(ids[kept]) == set(ids[rank[:cap]])
    assert dist[kept].max() <= dist[~kept].min()
    tie = dist[kept].max()
    if (dist[~kept] == tie).any():                           # a tie at the cut: lower ids stay
        assert ids[kept & (dist == tie)].max() < ids[~kept & (dist == tie)].min()


def test_godot_keeps_the_first_512_of_each_type_in_scene_order(rng):
    n_point, n_spot = 700, 40
    ids = _shuffled(rng, n_point + n_spot)
    types = np.where(ids < n_point, LIGHT_POINT, LIGHT_SPOT).astype(np.uint8)
    dist = rng.uniform(1, 50, len(ids))                      # never read: not distance
    kept = caps.keep("godot-512", ids, types, dist)
    assert set(ids[kept]) == set(range(512)) | set(range(n_point, n_point + n_spot))


def test_godot_gives_each_type_its_own_budget(rng):
    ids = np.arange(4 * 520)
    types = (ids % 4).astype(np.uint8)                       # 520 of each type
    kept = caps.keep("godot-512", ids, types, np.zeros(len(ids)))
    assert [int(kept[types == t].sum()) for t in range(4)] == [512] * 4
    for t in range(4):                                       # the last 8 of each type go
        assert (ids[(types == t) & ~kept] > ids[(types == t) & kept].max()).all()


def test_hdrp_view_caps_punctual_at_512_and_area_at_64_in_scene_order(rng):
    n = 700
    ids = _shuffled(rng, n)
    types = np.full(n, LIGHT_POINT, np.uint8)
    types[ids % 7 == 1] = LIGHT_SPOT
    types[ids % 7 == 2] = LIGHT_BOX                          # HDRP's box spot: punctual
    types[ids % 7 == 3] = LIGHT_CAPSULE                      # HDRP's tube light: area
    kept = caps.keep("hdrp-view", ids, types, rng.random(n))
    punctual = types != LIGHT_CAPSULE
    assert kept[punctual].sum() == 512 and kept[~punctual].sum() == 64
    assert set(ids[punctual & kept]) == set(np.sort(ids[punctual])[:512])
    assert set(ids[~punctual & kept]) == set(np.sort(ids[~punctual])[:64])


def test_a_cap_of_zero_or_an_unknown_order_is_refused():
    with pytest.raises(ValueError):
        caps.Policy("zero", ((caps.ALL_TYPES, 0),), caps.NEAREST, "")
    with pytest.raises(ValueError):
        caps.Policy("odd", ((caps.ALL_TYPES, 8),), "brightest", "")


def test_camera_distance_is_from_the_eye():
    m = np.eye(4)
    m[:3, 3] = (-1.0, -2.0, -3.0)                            # the eye at (1, 2, 3)
    d = caps.camera_distance(np.array([[1.0, 2.0, 3.0], [4.0, 6.0, 3.0]]), m)
    assert np.allclose(d, [0.0, 5.0])


def _frame(rng, n=120):
    """n point lights in front of a camera at (0, 3, 10) looking down -z."""
    lights = make_lights(n)
    lights["position"] = rng.uniform((-6, 0, -30), (6, 6, 5), (n, 3))
    lights["radius"] = rng.uniform(0.5, 3.0, n)
    lights["color"] = 1.0
    lights["intensity"] = 1.0
    cam = frame_camera(Camera((0.0, 3.0, 10.0), (0.0, 1.0, -20.0), near=0.1, far=200.0), 64, 36)
    return lights, cam


def test_prepare_capped_keeps_the_nearest_and_drops_the_rest(rng):
    lights, cam = _frame(rng)
    full = cpuframe.prepare_lights(lights, cam, cpuframe.StageTimes())
    same, none = cpuframe.prepare_capped_lights(lights, cam, cpuframe.StageTimes())
    assert not len(none) and np.array_equal(same.ids, full.ids)      # none: nothing changes
    assert len(full) > 40
    pl, dropped = cpuframe.prepare_capped_lights(lights, cam, cpuframe.StageTimes(),
                                                 cap_policy="urp-16")
    assert len(pl) == 16 and len(dropped) == len(full) - 16
    assert set(pl.ids.tolist()) | set(dropped.tolist()) == set(full.ids.tolist())
    d = caps.camera_distance(lights["position"], cam.view_from_world)
    assert d[pl.ids].max() <= d[dropped].min()
    # still depth sorted, ties in scene order, as the uncapped stage
    assert np.array_equal(pl.ids, full.ids[np.isin(full.ids, pl.ids)])


def test_without_culls_the_dropped_lights_and_keeps_every_id(rng):
    lights, cam = _frame(rng)
    full = cpuframe.prepare_lights(lights, cam, cpuframe.StageTimes())
    gone = full.ids[::3]
    out = caps.without(lights, gone, cam.view_from_world)
    keyed, _ = lightsmod.cull(out, cam)
    seen = set((keyed & np.uint64(0xFFFFFFFF)).astype(np.int64).tolist())
    assert seen == set(full.ids.tolist()) - set(gone.tolist())
    keep = np.setdiff1d(np.arange(len(lights)), gone)
    for name in lights.dtype.names:                                     # the others untouched
        assert np.array_equal(out[name][keep], lights[name][keep])


def test_hdrps_sort_key_orders_category_then_gpu_type_then_index():
    # PackLightSortKey: punctual before area; within punctual Point (1) < Spot (2) <
    # ProjectorBox (4); then the visible index (the scene id), whatever the shape's lab id
    types = np.array([LIGHT_CAPSULE, LIGHT_BOX, LIGHT_SPOT, LIGHT_POINT, LIGHT_POINT], np.uint8)
    ids = np.array([0, 1, 2, 9, 3])
    order = np.argsort(caps.hdrp_sort_key(types, ids)).tolist()
    assert order == [4, 3, 2, 1, 0]
    big = caps.hdrp_sort_key(np.zeros(2, np.uint8), np.array([70000, 2**32 - 1]))
    assert big[0] < big[1] < caps.hdrp_sort_key(np.array([LIGHT_SPOT]), np.array([0]))[0]


def test_tile_keep_keeps_the_lowest_keys_of_each_category_in_each_tile(rng):
    n = 400
    tiles = rng.integers(0, 5, n)
    ids = rng.permutation(n)
    types = rng.choice([LIGHT_POINT, LIGHT_SPOT, LIGHT_BOX, LIGHT_CAPSULE], n, p=[.5, .2, .1, .2]).astype(np.uint8)
    kept = caps.tile_keep("hdrp-fptl-24", tiles, types, ids)
    key = caps.hdrp_sort_key(types, ids)
    for t in range(5):
        for group in (caps.HDRP_PUNCTUAL, caps.HDRP_AREA):
            here = (tiles == t) & np.isin(types, group)
            assert kept[here].sum() == min(24, here.sum())
            if (here & ~kept).any():                           # past the cap: higher keys only
                assert key[here & kept].max() < key[here & ~kept].min()
    assert (~kept).any() and kept[tiles == 9].size == 0


def test_a_per_tile_policy_drops_nothing_from_the_view(rng):
    lights, cam = _frame(rng)
    full = cpuframe.prepare_lights(lights, cam, cpuframe.StageTimes())
    for name in caps.TILE_NAMES:
        pl, dropped = cpuframe.prepare_capped_lights(lights, cam, cpuframe.StageTimes(),
                                                     cap_policy=name)
        assert not len(dropped) and np.array_equal(pl.ids, full.ids)
    assert caps.TILE_NAMES == ("hdrp-fptl-24", "hdrp-fptl-63")
    with pytest.raises(ValueError):
        caps.tile_keep("urp-16", np.zeros(1), np.zeros(1, np.uint8), np.zeros(1))
