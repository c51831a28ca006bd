"""Scenes and readers the fptl and feature-variant tests share (test_fptl, test_fptl_tile_caps,
test_feature_variants, test_fptl_variants): fptl's lists decoded from what shading reads,
crowds of big lights that light every pixel, a capped frame with its check, and the variant
tests' mask scene."""
from __future__ import annotations

import numpy as np

from app.exactness import check
from app.techniques import REGISTRY, fptl
from scenes.geometry import box_mesh
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_SPOT, LIGHT_TYPES, Camera, make_lights
from tests.helpers import make_scene

T, BRUTE = REGISTRY["fptl"], REGISTRY["brute"]
CAP_SIZE = (48, 32)          # the per-tile cap tests' frame: 3 x 2 tiles of 16 px


def read_lists(r, res):
    """{cell: [light indices]} decoded from what shading reads (fptl_common.glsl): the
    list's words, whose in-band state gives its length and whether it spilled (then the
    spill heads) or shades every light (then every light); checking the R10G10B10A2
    blocks' counts and the state against the cells' records on the way; and the records."""
    n = res.meta["stats"]["visible_lights"]
    bits = res.meta["stats"]["index_bits"]
    words = fptl.list_words(bits)
    cells = r.read("fptl_cells").view(fptl.FPTL_CELL)
    lists = r.read("fptl_lists").reshape(len(cells), words)
    heads = r.read("fptl_spill_heads").reshape(-1, len(cells), 2)
    spill = r.read("fptl_spill")
    per, mask = {10: 3, 16: 2, 32: 1}[bits], {10: 0x3FF, 16: 0xFFFF, 32: 0xFFFFFFFF}[bits]
    h0 = fptl.head_words(bits)
    in_band, state = fptl.decode_state(lists, bits)
    out = {}
    for c, rec in enumerate(cells):
        listed = min(int(rec["pruned"]), fptl.LIST_CAP)
        assert state[c] == rec["flags"] & fptl.STATE, (c, state[c], rec["flags"])
        full = bool(state[c] & fptl.FLAG_POOL_FULL)
        if not full:
            assert in_band[c] == listed, (c, in_band[c], listed)
        idx = [int(lists[c, h0 + k // per] >> (32 // per * (k % per))) & mask for k in range(listed)]
        counts = (lists[c] >> 30).tolist()
        if bits != 10:                                   # the count word
            assert lists[c, 0] == (0 if full else listed) | int(state[c]) << 8, c
        elif full:
            assert tuple(counts) == fptl.POOL_FULL_COUNTS, (c, counts)
        elif state[c]:
            assert tuple(counts) == fptl.SPILLED_COUNTS and listed == 24, (c, counts)
        else:              # the chapter's blocks: 2-bit count of the active indices
            assert counts == [min(max(listed - 3 * b, 0), 3) for b in range(8)], (c, counts)
            assert sum(counts) == listed
        if state[c] & fptl.FLAG_SPILLED:
            for h in heads[:, c]:
                idx += spill[h[0]:h[0] + h[1]].tolist()
        else:
            assert not heads[:, c, 1].any(), c
        if full:
            idx = list(range(n))                         # the cell shades every light
        else:
            assert len(idx) == rec["pruned"], c
        assert all(i < n for i in idx)
        out[c] = idx
    return out, cells


def point_crowd(n: int, radius=40.0, seed=0):
    """n big point lights around the middle of the view: every one lights every pixel."""
    rng = np.random.default_rng(seed)
    L = make_lights(n)
    L["position"] = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(0, 3, n), rng.uniform(-14, -6, n)])
    L["radius"] = radius
    L["color"] = rng.uniform(0.2, 1.0, (n, 3))
    return L


def capped_crowd(points: int, capsules: int, seed: int = 0):
    """Big point lights and capsules around the middle of the view, each lighting every
    pixel: every lit tile's categories hold all of them.  Scene ids: points first."""
    rng = np.random.default_rng(seed)
    n = points + capsules
    L = make_lights(n)
    L["type"][points:] = LIGHT_CAPSULE
    L["position"] = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(0, 3, n), rng.uniform(-14, -6, n)])
    L["direction"] = (1.0, 0.0, 0.0)
    L["length"][points:] = 1.0
    L["radius"] = 40.0
    L["color"] = rng.uniform(0.2, 1.0, (n, 3))
    return L


def render_checked(r, policy: str, technique=T):
    opts = technique.Options.make({"cap_policy": policy})
    res = r.render(technique, opts=opts)
    ref = r.render(BRUTE)
    return res, ref, check(res, ref, r, technique, BRUTE, {"opts": opts})


def mask_scene(size=(96, 64), shapes=LIGHT_TYPES):
    """A floor, specular far half and matte near half, seen from above with sky around it;
    two lights of each shape (one over each half) apart from the others, a point light
    between two of them (mixed tiles), and a heap of twelve points (hybrid's tree cells)."""
    far = box_mesh((-16, -0.1, -8), (16, 0.0, 0.0))
    far.roughness = 0.3
    near = box_mesh((-16, -0.1, 0.0), (16, 0.0, 8))
    L = make_lights(21)
    L["type"][:8] = np.repeat(np.arange(4), 2)
    L["position"][:8] = [(x, 0.6, z) for x in (-9.0, -3.0, 3.0, 9.0) for z in (-4.0, 4.0)]
    L["radius"][:8] = 2.2
    L["intensity"] = 4.0
    spot, cap, box = (L["type"] == t for t in (LIGHT_SPOT, LIGHT_CAPSULE, LIGHT_BOX))
    L["cos_outer"][spot], L["cos_inner"][spot] = np.cos(np.radians(60)), np.cos(np.radians(30))
    L["direction"][cap], L["length"][cap], L["radius"][cap] = (1.0, 0.0, 0.0), 2.0, 1.0
    L["up"][box], L["extent"][box], L["position"][box, 1] = (0.0, 0.0, 1.0), (1.5, 1.5, 1.0), 0.0
    L["position"][8], L["radius"][8] = (6.0, 0.5, 0.0), 2.0
    rng = np.random.default_rng(1)
    L["position"][9:] = (-13.0, 0.3, 4.0) + rng.uniform(-0.6, 0.6, (12, 3))
    L["radius"][9:] = rng.uniform(0.8, 1.6, 12)
    L = L[np.isin(L["type"], [LIGHT_TYPES.index(s) for s in shapes])]
    cam = Camera((0.0, 16.0, 9.0), (0.0, 0.0, 0.0), fov_y_deg=70.0, near=0.1, far=100.0)
    return make_scene(L, [far, near], size=size, camera=cam, max_depth=60.0)
