"""The floor technique (role "floor", the perfect culler) through Renderer.render like any
other: exact per-pixel lists, several bands of lists when one storage block cannot hold
them, its list building untimed, and render(samples=N) repeating only its timed passes."""
import numpy as np

from app.pipeline.renderer import Renderer
from app.techniques import with_role
from tests.helpers import make_scene, random_lights


def test_floor_exact_lists_in_bands(gl, rng, monkeypatch):
    floor, reference = with_role("floor"), with_role("reference")
    scene = make_scene(random_lights(rng, 300, (-12, 0, -40), (12, 8, 5)), size=(61, 37))
    with Renderer(scene) as r:
        ref = r.render(reference)
        one = r.render(floor)
        assert one.meta["stats"]["bands"] == 1
        gl_rows = one.contrib_count[::-1].astype(np.int64)      # GL row order, bottom first
        per_group = [int(gl_rows[y:y + 8].sum()) for y in range(0, gl_rows.shape[0], 8)]
        assert sum(per_group) > max(per_group)
        # force several bands of whole 8-row groups (monkeypatch restores the limit)
        monkeypatch.setattr(floor, "max_band_bytes", 4 * max(per_group))
        banded = r.render(floor)
        assert banded.meta["stats"]["bands"] > 1
        sampled = r.render(floor, samples=3)
        for res in (one, banded, sampled):
            assert (res.evaluated == res.contrib_count).all()
            assert (res.contrib_count == ref.contrib_count).all()
            assert (res.contrib_hash == ref.contrib_hash).all()
            assert np.array_equal(res.image, ref.image)
            assert set(res.meta["gpu_ms"]) == {"gbuffer", "shade"}     # set-up is untimed
            assert res.meta["setup_ms"]
        assert len(sampled.meta["samples"]) == 3
        assert all(set(s["gpu_ms"]) == {"gbuffer", "shade"} for s in sampled.meta["samples"])
        assert ref.contrib_count.sum() > 0
