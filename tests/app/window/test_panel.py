"""The window's parts that need no GL: the panel's model (controls read from the techniques'
declarations, the one `apply` path), camera path files, timers, frame-cost predictions, the
HUD's text and app.images' one definition of what a person sees (camera path files:
tests/scenes/test_camera_path.py)."""
from __future__ import annotations

import json
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pytest

from app import images
from app.errors import UserError
from app.techniques import REGISTRY
from app.techniques.base import Technique
from app.techniques.options import TechniqueOptions, choice, option
from app.window.hud import exposure_text, hud_lines
from app.given_options import GivenOptions
from app.window.panel import LabState, Panel, panel_keys
from app.window.probe import FrameCosts
from app.window.timers import Timers
from app.views import views_of
from app.window.views import Overlay, view_note


def state(technique="hybrid", given=None, **kw):
    kw.setdefault("lights", 4096)
    return LabState(REGISTRY, technique=technique, options=GivenOptions(given or {}), **kw)


def test_controls_are_the_techniques_declared_options():
    for t in REGISTRY.values():
        p = Panel(state(t.name))
        keys = [c.key for c in p.controls() if c.section == "options"]
        assert keys == list(t.Options.names()) + ["defaults"]
        for c in p.controls():
            if c.section == "options" and c.kind != "button":
                spec = {s.name: s for s in t.Options.specs()}[c.key]
                assert (c.lo, c.hi, c.power_of_two) == (spec.lo, spec.hi, spec.power_of_two)
                assert spec.help in c.help and spec.flag in c.help
    assert [c.choices for c in Panel(state()).controls() if c.key == "view"][0] == views_of(REGISTRY["hybrid"])


def test_apply_is_checked_and_changes_the_technique_options():
    s = state("tree", {"tile": 32})
    p = Panel(s)
    p.apply("lights_per_leaf", "2")                  # a string, as --keys gives it
    opts, _ = s.options.for_technique(REGISTRY["tree"])
    assert opts.lights_per_leaf == 2 and opts.tile == 32
    v = s.version
    with pytest.raises(UserError, match="--tile must be in 4..256"):
        p.apply("tile", 7000)
    with pytest.raises(UserError, match="power of two"):
        p.apply("max_leaves", 48)
    assert s.version == v and s.options.for_technique(REGISTRY["tree"])[0].tile == 32
    with pytest.raises(UserError, match="no control 'slices' for tree"):
        p.apply("slices", 8)
    p.apply("defaults")
    assert s.options.for_technique(REGISTRY["tree"])[0].lights_per_leaf != 2 or \
        REGISTRY["tree"].Options().lights_per_leaf == 2
    assert s.options.for_technique(REGISTRY["tree"])[0].tile == 32     # the command line's stays


def test_a_choice_option_is_a_combo_of_its_names():
    s = state("fptl")
    p = Panel(s)
    spec = REGISTRY["fptl"].Options.spec("fptl_variant")
    c = p.control("fptl_variant")
    assert c.kind == "choice" and c.choices == spec.choices and c.value == spec.choices[0]
    p.apply("fptl_variant", spec.choices[2])             # the combo sets a name
    assert s.options.for_technique(REGISTRY["fptl"])[0].fptl_variant == 2
    assert p.control("fptl_variant").value == spec.choices[2]
    with pytest.raises(UserError, match="must be one of 0 "):
        p.apply("fptl_variant", "no such variant")
    assert s.options.hud_line(REGISTRY["fptl"]) == f'options: --fptl-variant "{spec.choices[2]}"'


def test_each_technique_is_offered_the_choices_it_takes():
    """A choice's combo holds the values the technique's Options take (the per-tile
    hdrp-fptl-* cap policies: fptl's alone), each accepted and each left out refused by the
    Options' own check; the current value stays offered."""
    offered = {}
    for t in REGISTRY.values():
        for spec in (s for s in t.Options.specs() if s.choices):
            got = Panel(state(t.name)).control(spec.name).choices
            for k, name in enumerate(spec.choices):
                if name in got:
                    t.Options(**{spec.name: k})
                else:
                    with pytest.raises(UserError):
                        t.Options(**{spec.name: k})
            offered[t.name, spec.name] = got
    tile_caps = {"hdrp-fptl-24", "hdrp-fptl-63"}
    assert tile_caps <= set(offered["fptl", "cap_policy"])
    assert not tile_caps & set(offered["tiled", "cap_policy"]) and "urp-16" in offered["tiled", "cap_policy"]


@dataclass(frozen=True)
class PairedOptions(TechniqueOptions):
    mode: int = choice("plain", ("plain", "paired"), "a mode that needs `pair` on")
    pair: bool = option(False, "what the paired mode needs")

    def check_modes(self) -> None:
        if self.mode == 1 and not self.pair:
            raise UserError("--mode paired takes --pair")


def test_a_choice_taken_only_with_another_option_is_offered_once_chosen():
    class Paired(Technique):             # not registered: a test's own
        name, Options = "paired", PairedOptions
    s = LabState({"paired": Paired()}, technique="paired", options=GivenOptions({}), lights=16)
    p = Panel(s)
    assert p.control("mode").choices == ("plain",)
    p.apply("pair", True)
    p.apply("mode", "paired")                  # as --keys or the command line would set it
    assert p.control("mode").choices == ("plain", "paired") and p.control("mode").value == "paired"


def test_panel_display_and_lights_controls():
    s = state("clustered")
    p = Panel(s)
    p.apply("exposure_ev", "2.5")
    assert not s.exposure_auto and s.exposure_manual == pytest.approx(2 ** 2.5)
    p.apply("exposure_auto", "on")
    p.apply("ambient", 0.1)
    p.apply("heat_max", 64)
    p.apply("heat_of", "exact")
    p.apply("heat_overlay", True)
    p.apply("lights", "1024")
    p.apply("seed", 7)
    p.apply("distribution", "uniform")
    assert (s.exposure_auto, s.ambient, s.heat_max, s.heat_of, s.heat_overlay, s.lights, s.seed,
            s.distribution) == (True, 0.1, 64.0, "exact", True, 1024, 7, "uniform")
    with pytest.raises(UserError):
        p.apply("ambient", 2.0)
    with pytest.raises(UserError):
        p.apply("heat_of", "nodes")
    with pytest.raises(UserError, match="at most"):
        p.apply("lights", 10**9)
    p.apply("technique", "brute")                    # it has no slices: back to shaded
    s.view = "shaded"
    with pytest.raises(UserError, match="brute has no tiles view"):
        p.apply("view", "tiles")
    f = state("clustered", builtin=False, file_lights=10, lights=10)
    with pytest.raises(UserError, match="the scene file has 10"):
        Panel(f).apply("lights", 11)
    assert "seed" not in [c.key for c in Panel(f).controls()]


def test_switching_technique_keeps_a_view_it_has_or_falls_back():
    s = state("hybrid", view="slices")
    s.set_technique("clustered")
    assert s.view == "slices" and not s.messages
    s.set_technique("tree")
    assert s.view == "shaded" and s.messages == ["tree has no slices view: shaded"]
    s.split_with = "tiled"
    s.set_technique("tiled")
    assert s.split_with != "tiled"


def test_every_panel_key_is_scriptable():
    keys = panel_keys(REGISTRY)
    assert {"tile", "lights_per_leaf", "radius_scale", "exposure_ev", "heat_max"} <= keys
    for t in REGISTRY.values():
        for c in Panel(state(t.name)).controls():
            assert c.key in keys


def test_timers_rolling_median_min_and_history():
    t = Timers()
    t.add("a", {"shade": 99.0}, {"cull": 1.0}, 120.0)           # first frame: compiles, not kept
    for v in (3.0, 1.0, 2.0, 10.0):
        t.add("a", {"shade": v}, {"cull": 1.0}, 20.0)
    med, lo, n = t.summary()["gpu shade"]
    assert (med, lo, n) == (2.5, 1.0, 4) and t.history("gpu shade") == [3.0, 1.0, 2.0, 10.0]
    t.add("b", {"shade": 5.0}, {}, 1.0)                          # a new configuration: new history
    assert t.summary() == {}


def test_frame_cost_prediction_scales_with_pixels_and_lights():
    c = FrameCosts()
    assert c.predict("brute", 100, 10) is None
    c.record("brute", 50.0, 1000, 100)
    assert c.predict("brute", 4000, 200) == pytest.approx(400.0)


def test_hud_text_and_view_notes():
    none = Overlay.of(None)
    grid = SimpleNamespace(tile=32, tiles_x=5, tiles_y=3, slices=1, slice_scale=0.0, slice_bias=0.0)
    tiles = Overlay.of(grid)
    assert view_note("tiles", "tree", tiles, 1) == "tiles: 32 px, 5x3 (tree's grid)"
    assert view_note("slices", "tree", tiles, 1).startswith("no depth slices")
    assert view_note("tiles", "perfect", none, 1).startswith("no tiles")
    assert view_note("shaded", "tree", tiles, 1) is None
    assert "37" in view_note("heat", "tree", tiles, 37) and "log2(1 + n)" in view_note("heat", "tree", tiles, 37)
    assert view_note("diff", "tree", tiles, 1, differ=0).endswith("0 pixels differ (the light sets are exact)")
    assert "pending" in view_note("diff", "tree", tiles, 1, differ=None) or \
        "not rendered" in view_note("diff", "tree", tiles, 1, differ=None)

    opts = GivenOptions({"tile": 32, "lights_per_leaf": 2})
    tree, ignored = opts.for_technique(REGISTRY["tree"])
    assert type(tree) is REGISTRY["tree"].Options and tree.tile == 32 and ignored == ()
    brute, ignored = opts.for_technique(REGISTRY["brute"])
    # brute takes neither: its own options (stochastic culling's) stay at their defaults
    assert brute == REGISTRY["brute"].Options() and ignored == ("lights_per_leaf", "tile")
    assert opts.hud_line(REGISTRY["tree"]) == "options: --tile 32  --lights-per-leaf 2"
    line = opts.hud_line(REGISTRY["brute"])
    assert line == "options: defaults   (not taken by brute: --tile 32  --lights-per-leaf 2)"
    opts.set(REGISTRY["tree"], "tile", 16)
    assert opts.hud_line(REGISTRY["tree"]) == "options: --tile 16  --lights-per-leaf 2"

    f = {"technique": "brute", "view": "heat", "size": [160, 90], "lights": 32, "visible_lights": 31,
         "evaluated_per_pixel": 31.0, "exact_per_pixel": 0.5, "cpu_ms": {"cull": 1.0},
         "gpu_ms": {"shade": 2.0}, "setup_ms": {}}
    lines = hud_lines(f, position="1/6", role="reference", software=True, playing=False,
                      options=line, note=view_note("heat", "brute", none, 31),
                      exposure=exposure_text(4.0, True, 0.02))
    assert lines[0].startswith("brute [reference] (1/6)   view: heat")
    assert line in lines and "exposure auto x4 (EV +2.0)   ambient 0.02 (display only)" in lines
    assert "capped" not in lines[1]
    capped = hud_lines(dict(f, capped={"policy": "urp-16", "lights": 15}), position="1/6",
                       role="technique", software=True, playing=False, options=line, note=None)
    assert capped[1].endswith("capped: 15 lights dropped by urp-16 (not exact, on purpose)")
    assert lines[2] == "CPU 1.0 ms: cull 1.0"
    two = hud_lines(dict(f, cpu_threads=2), position="1/6", role="technique", software=True,
                    playing=False, options=line, note=None)
    assert two[2] == "CPU 1.0 ms (2 threads): cull 1.0"


def test_one_heat_definition_and_exposure():
    v = np.array([[0, 1, 3], [7, 15, 100]])
    covered = np.array([[True, True, True], [True, True, False]])
    assert images.heat_max(v, covered) == 15.0 and images.heat_max(v, covered, 64) == 64.0
    rgb = images.heat_rgb(v, covered, 15.0)
    assert (rgb[1, 2] == 0).all()                                # sky black
    assert (rgb[0, 0] == images.to8(np.array([images.HEAT_ZERO]))).all()   # covered zero grey
    t = images.heat_t(np.array([0, 1, 3, 15, 1000]), 15)
    assert t[0] == 0 and t[3] == 1 and t[4] == 1 and np.all(np.diff(t) >= 0)
    assert t[1] == pytest.approx(0.25)                           # log2(2) / log2(16)
    for top in (1, 7, 37, 1000, 65536):
        ticks = images.heat_ticks(top)
        assert ticks[0] == 0 and ticks[-1] == top and ticks == sorted(ticks)
    # exposure: the percentile of the lit pixels lands on the target
    img = np.zeros((10, 100, 3), np.float32)
    img[:, :50] = 0.25
    img[:, 50:] = 4.0
    e = images.auto_exposure(img, np.ones((10, 100), bool))
    assert 4.0 * e == pytest.approx(images.EXPOSURE_TARGET, rel=0.25)   # within a bin
    assert images.auto_exposure(np.zeros((4, 4, 3), np.float32), np.ones((4, 4), bool)) == 1.0
    # ambient is display only and lifts unlit geometry off black
    dark = images.display(np.zeros((1, 1, 3), np.float32), np.full((1, 1, 3), 0.5, np.float32), 8.0, 0.02)
    assert 20 < int(dark.max()) < 60


def test_a_panel_change_the_mode_refuses_is_rolled_back():
    """raster: stencil on, then cluster mode (which ignores the stencil) is refused in one
    line and the panel keeps the last accepted options (app.given_options' rule)."""
    raster = REGISTRY["raster"]
    w = GivenOptions({})
    w.set(raster, "stencil", True)
    with pytest.raises(UserError, match="ignored in cluster mode"):
        w.set(raster, "cluster", 1)
    opts, _ = w.for_technique(raster)
    assert opts.stencil and opts.cluster == 0


def test_technique_chooser_reaches_past_the_ninth():
    """Keys 1-9 choose the first nine; T (next_technique) walks every one past the ninth too,
    and the panel's technique list holds them all."""
    registry = dict(REGISTRY)
    while len(registry) < 11:
        registry[f"extra{len(registry)}"] = REGISTRY["brute"]
    names = list(registry)
    s = LabState(registry, technique=names[8], options=GivenOptions({}), lights=64)
    for k in range(9, len(names)):
        s.next_technique()
        assert s.technique == names[k]
    s.next_technique()
    assert s.technique == names[0]                               # round again
    s.choose_number(9)
    assert s.technique == names[8]
    with pytest.raises(UserError, match=f"no technique {len(names) + 1}: {len(names)} registered"):
        s.choose_number(len(names) + 1)
    technique = next(c for c in Panel(s).controls() if c.key == "technique")
    assert technique.choices == tuple(names)


def test_heat_scale_one_rule():
    """app.images.heat_top is the heat scale's top for capture, the window (both halves of
    the split) and the report; maps_top one scale over a technique's maps."""
    from app.window.figures import heat_scale, heat_top
    assert images.heat_top(0) == 1.0 and images.heat_top(37) == 37.0 and images.heat_top(37, 64) == 64.0
    s = state("clustered")
    sums, split = {"max_evaluated": 12, "max_exact": 3}, {"max_evaluated": 40, "max_exact": 2}
    assert heat_top(s, sums, None) == 12 and heat_top(s, sums, split) == 40
    s.heat_of = "exact"
    assert heat_top(s, sums, split) == 3
    s.heat_max = 64
    assert heat_top(s, sums, split) == 64
    f = {"heat_of": "exact", "heat_max": 64.0}
    assert heat_scale(f, "heat", s, ("", "", 0.0)) == (64.0, "exact lights / pixel, log2(1 + n); top 64 (fixed)")
    assert heat_scale(f, "shaded", s, ("", "", 0.0)) is None
    assert heat_scale(f, "maps", s, ("coarse", "lights / tile", 9.0)) == (9.0, "coarse: lights / tile, log2(1 + n)")
    maps = {"a": (np.array([[1, 7]]), "x"), "b": (np.zeros((0, 0)), "y")}
    assert images.maps_top(maps) == 7.0 and images.maps_top({}) == 1.0
    full = images.cells_to_pixels(np.array([[1, 2], [3, 4]]), (5, 3))
    assert full.shape == (3, 5) and full[0].tolist() == [1, 1, 1, 2, 2] and full[2, 4] == 4
