"""The dump of the contract (docs/contracts.md "Contract: capture and dump"): per pixel, row 0 = top,
image float32 (H,W,3), depth float32, evaluated / contrib_count / contrib_hash uint32, and
meta, a JSON string."""
from __future__ import annotations

import json

import numpy as np

from cpu_prep.layouts import mix     # the contract's hash of a light id (this module's name too)

FIELDS = ("image", "depth", "evaluated", "contrib_count", "contrib_hash")
# a scene with transparent surfaces adds, per layer (L, H, W): contrib_count_t, contrib_hash_t,
# evaluated_t uint32 (0 where the layer has no fragment), depth_t float32 (app/pipeline/transparent.py)
LAYER_FIELDS = ("contrib_count_t", "contrib_hash_t", "depth_t", "evaluated_t")
# a fog scene's per-froxel light sets, (D, H, W) uint32, row 0 the top (app/pipeline/fog.py)
FOG_FIELDS = ("froxel_count", "froxel_hash")


def write_dump(path, result) -> None:
    arrays = {
        "image": result.image.astype(np.float32),
        "depth": result.depth.astype(np.float32),
        "evaluated": result.evaluated.astype(np.uint32),
        "contrib_count": result.contrib_count.astype(np.uint32),
        "contrib_hash": result.contrib_hash.astype(np.uint32),
    }
    if getattr(result, "contrib_count_t", None) is not None:    # transparent layers (L, H, W)
        arrays.update({k: getattr(result, k).astype(np.float32 if k == "depth_t" else np.uint32)
                       for k in LAYER_FIELDS})
    for k in FOG_FIELDS:
        if getattr(result, k, None) is not None:
            arrays[k] = getattr(result, k).astype(np.uint32)
    np.savez_compressed(path, **arrays, meta=np.array(json.dumps(result.meta, sort_keys=True)))


def read_dump(path) -> dict:
    with np.load(path, allow_pickle=False) as d:
        out = {k: d[k] for k in FIELDS + LAYER_FIELDS if k in FIELDS or k in d}
        out.update({k: d[k] for k in FOG_FIELDS if k in d.files})
        out["meta"] = json.loads(str(d["meta"]))
    return out




def exactness(result, reference) -> tuple[int, int]:
    """(pixels whose count differs, pixels whose hash differs) between two frames."""
    return (int((result.contrib_count != reference.contrib_count).sum()),
            int((result.contrib_hash != reference.contrib_hash).sum()))
