"""The wave API: native subgroup ops and the 64-lane emulation give the same image; the
hybrid's three traversal cases all occur and are reported per wave."""
import numpy as np

from app.pipeline import gl as glmod
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from tests.helpers import takes
from scenes import load_scene


def test_native_and_emulated_waves_render_identically(gl):
    path = glmod.limits().native_wave
    assert path, "driver has neither GL_KHR_shader_subgroup nor GL_ARB_shader_ballot: native path untested"
    scene = load_scene("arena", lights=2048, seed=4)
    with Renderer(scene, (160, 90)) as r:
        wavy = [n for n in REGISTRY if takes(n, "native_wave")]
        assert wavy
        for name in wavy:
            # the mode of the defaults must use wave operations (clustered: scalarized)
            mode = {"scalarize": True} if "native_wave" in REGISTRY[name].Options().ignored() else {}
            emu = r.render(REGISTRY[name], 0, dict(mode, native_wave=False))
            nat = r.render(REGISTRY[name], 0, dict(mode, native_wave=True))
            assert emu.meta["wave"] == "emulated-64" and nat.meta["wave"] == f"native-{path}"
            for field in ("contrib_count", "contrib_hash", "evaluated", "nodes"):
                if field == "evaluated" and getattr(REGISTRY[name], "evaluates_per_wave", False):
                    # a scalarized loop evaluates the union of its wave's lights: a native
                    # subgroup is a part of the 8x8 group, so it evaluates a subset
                    assert (nat.evaluated <= emu.evaluated).all(), name
                    assert (nat.evaluated >= nat.contrib_count).all(), name
                    continue
                assert np.array_equal(getattr(emu, field), getattr(nat, field)), field
            assert np.array_equal(emu.image, nat.image)


def test_hybrid_reports_list_tree_and_mixed_waves(gl):
    scene = load_scene("city", lights=8192, seed=1)
    with Renderer(scene, (320, 180)) as r:
        res = r.render(REGISTRY["hybrid"])
    cases = res.wave["case_bits"] & 3
    assert {1, 2, 3} <= set(np.unique(cases).tolist()), np.unique(cases)
    shared = (res.wave["case_bits"] & 4) != 0
    assert shared.any() and (cases[shared] == 2).all()   # shared-memory trees: tree-only waves
    # longest loop of each wave bounds each of its lanes' work
    lanes = (res.evaluated + res.nodes)
    h, w = lanes.shape
    padded = np.zeros((res.wave.shape[0] * 8, res.wave.shape[1] * 8), np.int64)
    padded[:h, :w] = lanes[::-1]           # wave rows are in image order, lanes GL order
    per_wave = padded.reshape(res.wave.shape[0], 8, res.wave.shape[1], 8).max((1, 3))[::-1]
    assert np.array_equal(per_wave, res.wave["iterations"].astype(np.int64))


def test_scalarized_cells_walk_every_distinct_cell(gl):
    """clustered with scalarize: the same light sets per pixel; per wave the scalar loop walks
    each distinct cell once with all its entries, so it runs at least the longest lane's
    loop plus one round per cell (the slides: performance highly variable)."""
    scene = load_scene("city", lights=4096, seed=1)
    with Renderer(scene, (96, 54)) as r:
        plain = r.render(REGISTRY["clustered"], 0, {})
        for native in (False, True):
            sc = r.render(REGISTRY["clustered"], 0, {"scalarize": True, "native_wave": native})
            for field in ("contrib_count", "contrib_hash", "evaluated"):
                assert np.array_equal(getattr(sc, field), getattr(plain, field)), field
            busy = plain.wave["iterations"] > 0
            assert busy.any()
            assert (sc.wave["iterations"][busy] > plain.wave["iterations"][busy]).all()


def test_hybrid_counts_what_listing_2_chose(gl):
    """Waves are classified by the heuristic's choice: with every cell chosen a list
    (radius_scale tiny) there is no tree or mixed wave and no tree in the stats; the per-path
    counters of the meta come from the waves themselves; the general traversal visits the
    same nodes as the specialised paths."""
    scene = load_scene("city", lights=8192, seed=1)
    with Renderer(scene, (96, 54)) as r:
        lists = r.render(REGISTRY["hybrid"], 0, {"radius_scale": 1e-3})
        spec = r.render(REGISTRY["hybrid"], 0, {})
        general = r.render(REGISTRY["hybrid"], 0, {"specialised": False})
    st = lists.meta["stats"]
    assert st["trees"] == 0 and st["lists"] > 0
    assert set(np.unique(lists.wave["case_bits"] & 3).tolist()) <= {0, 1}
    assert st["waves_tree"] == st["waves_mixed"] == 0 and st["waves_list"] > 0
    s = spec.meta["stats"]
    assert s["trees"] > 0 and s["waves_tree"] + s["waves_mixed"] > 0
    assert s["waves_list"] == int(((spec.wave["case_bits"] & 3) == 1).sum())
    for f in ("contrib_hash", "evaluated", "nodes"):
        assert np.array_equal(getattr(spec, f), getattr(general, f)), f
    assert general.meta["stats"]["waves_shared_tree"] == 0 < s["waves_shared_tree"]
