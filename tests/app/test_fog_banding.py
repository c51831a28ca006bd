"""The banding case (app/fog_banding.py): the centre cell's list taken as a froxel's exact
set shows error on a froxel grid of its own and none on the matched grid; the script writes
both grids' images."""
import json

import numpy as np

from scenes import load_scene


def test_the_centre_cell_shortcut_bands_on_a_grid_of_its_own_only(gl):
    from app.fog_banding import banding
    from app.techniques import get
    scene = load_scene("hangar-fog", 1500)
    res = banding(scene, get("clustered"), (120, 68), (30, 17, 12), radius_scale=0.2)
    own, matched = res["30x17x12"], res["matched"]
    assert own["error"] > 1e-3 and own["pixels_off"] > 0.001
    assert matched["error"] == 0.0 and np.array_equal(matched["centre"], matched["exact"])
    assert not np.array_equal(own["exact"], matched["exact"])     # two grids, two images


def test_the_script_writes_both_grids_images(gl, tmp_path, capsys):
    from app import fog_banding
    fog_banding.main(["--size", "64x36", "--froxels", "16x9x8", "--lights", "300",
                      "--out", str(tmp_path)])
    out = json.loads(capsys.readouterr().out)
    assert set(out["grids"]) == {"16x9x8", "matched"}
    names = {p.name for p in tmp_path.iterdir()}
    assert names == {f"{g}-{k}.png" for g in out["grids"] for k in ("exact", "centre", "difference")}
