"""The window's feature-variant view (app/window/variant_view.py): its legend names each
program's colour, mask and tiles, and the view, driven in a headless scripted run, tints the
shaded image tile by tile."""
import numpy as np

from app.pipeline import features as feat
from app.window import variant_view as vv
from app.window.views import Overlay, view_note
from tests.app.window.test_window import LIT, load_rgb, run_window

STATS = {"variant_masks": [31, 0, 14], "feature_variants": 2, "variant_tile": 16,
         "variant_tiles": {"point+spot+capsule+box, specular": 5, "empty": 3, "spot+capsule+box": 1}}


def test_the_legend_names_colour_mask_and_tiles():
    entries = vv.legend(STATS)
    assert [(m, name, t) for m, name, _, t in entries] == \
        [(31, "red", 5), (0, vv.EMPTY[0], 3), (14, vv.GENERAL[0], 1)]
    text = vv.legend_text(STATS)
    assert text.startswith("16 px tiles: red point+spot+capsule+box, specular (5)")
    assert "white spot+capsule+box (1)" in text
    assert vv.legend_text({"variant_fallback": "no indirect dispatch"}) == "off (no indirect dispatch)"


def test_the_hud_note_is_the_legend():
    note = view_note("variants", "tiled", Overlay(), 0.0, map_label=vv.legend_text(STATS))
    assert note == "variants: " + vv.legend_text(STATS)


def test_tile_colours_follow_the_masks():
    colors = vv.tile_colors(STATS, np.array([31, 0, 14, 31], np.uint32))
    assert np.allclose(colors[0, :3] * 255, vv.PALETTE[0][1]) and np.allclose(colors[1, :3] * 255, vv.EMPTY[1])
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
