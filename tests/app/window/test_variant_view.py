"""The window's feature-variant view (app/window/variant_view.py): its legend (the panel's
list) gives each program's colour, mask and tiles, every program a colour of its own, and the
view, driven in a headless scripted run, tints the shaded image tile by tile."""
import numpy as np

from app.pipeline import features as feat
from app.techniques.variants import MAX_PROGRAMS
from app.window import variant_view as vv
from app.window.views import Overlay, view_note
from tests.app.window.window_run import LIT, load_rgb, run_window

STATS = {"variant_masks": [31, 0, 14], "feature_variants": 2, "variant_tile": 16,
         "variant_tiles": {"point+spot+capsule+box, specular": 5, "empty": 3, "spot+capsule+box": 1}}


def test_the_legend_lists_colour_mask_and_tiles():
    entries = vv.legend(STATS)
    assert [(e.mask, e.rgb, e.tiles, e.shares) for e in entries] == \
        [(31, vv.PALETTE[0], 5, ""), (0, vv.EMPTY, 3, "no lights"), (14, vv.GENERAL, 1, "general program")]
    assert entries[0].label == "point+spot+capsule+box, specular"
    note = vv.legend_note(STATS)
    assert note.startswith("16 px tiles, 3 masks (2 programs, 1 by the general program")
    assert vv.legend_note({"variant_fallback": "no indirect dispatch"}) == "off (no indirect dispatch)"
    assert view_note("variants", "tiled", Overlay(), 0.0, map_label=note) == "variants: " + note


def test_every_program_of_a_frame_has_its_own_colour():
    """As many shaded masks as a frame gives programs (MAX_PROGRAMS), every non-empty one:
    each its own colour, none grey or white; past the cap they share the general white."""
    shaded = [m for m in range(feat.MASKS) if m & feat.SHAPE_MASK][:MAX_PROGRAMS + 3]
    stats = {"variant_masks": shaded, "feature_variants": MAX_PROGRAMS, "variant_tile": 8,
             "variant_tiles": {feat.mask_label(m): 1 for m in shaded}}
    entries = vv.legend(stats)
    own = [e.rgb for e in entries[:MAX_PROGRAMS]]
    assert len(set(own)) == MAX_PROGRAMS and not {vv.EMPTY, vv.GENERAL} & set(own)
    assert all(e.rgb == vv.GENERAL and e.shares for e in entries[MAX_PROGRAMS:])
    lab = vv._lab(np.array(own))
    gaps = np.linalg.norm(lab[:, None] - lab[None], axis=2) + np.eye(len(own)) * 1e9
    assert gaps.min() > 20, gaps.min()            # CIELAB: told apart at a glance


def test_tile_colours_follow_the_masks():
    colors = vv.tile_colors(STATS, np.array([31, 0, 14, 31], np.uint32))
    assert np.allclose(colors[0, :3] * 255, vv.PALETTE[0]) and np.allclose(colors[1, :3] * 255, vv.EMPTY)
    assert np.array_equal(colors[0], colors[3]) and (colors[:, 3] == vv.ALPHA).all()
    assert feat.mask_label(0) == "empty"


def test_the_view_draws_the_variant_tiles(tmp_path):
    """A headless scripted run to the view: the image shows the 16-px tiles' dark borders
    over the tint (columns 0, 16, 32, ...)."""
    shot = tmp_path / "variants.png"
    frames, _, _ = run_window(LIT + ["--technique", "tiled", "--feature-variants", "--tile", "16",
                                     "--no-hud", "--frames", "6", "--keys", "v,v,v,v,v",
                                     "--screenshot", str(shot)])
    assert frames[-1]["view"] == "variants"
    img = load_rgb(shot).sum(2)
    cols = np.arange(img.shape[1])
    border, inner = img[:, cols % 16 == 0].mean(), img[:, cols % 16 == 8].mean()
    assert border < 0.6 * inner, (border, inner)
