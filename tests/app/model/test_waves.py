"""The wave replay (app/model/waves/) against the shaders' own counters: the per-pixel work
it implies (lights evaluated, tree nodes visited) equals PixelStats' at every pixel, on every
builtin scene and for every technique, the native wave path at llvmpipe's subgroup size (8)
included; the lights it finds affecting equal contrib_count up to the float32 rounding of its
copy of the affects test."""
from __future__ import annotations

import numpy as np
import pytest

from app.model import predict, waves
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, parts
from scenes import BUILTIN_SCENES, load_scene
from tests.app.model.replay_check import check, gl_order
from tests.helpers import pixel_oracle

SIZE = (72, 48)                  # 9 x 6 groups: whole 8x8 groups and 4-row halves (W = 32)
LIGHTS = 1536

# Options whose loops the replay walks differently (every technique also runs at defaults).
VARIANTS = [
    ("clustered", {"scalarize": True}), ("clustered", {"duplicated": True}),
    ("tree", {"duplicated": True}), ("tree", {"lights_per_leaf": 1}),
    ("hybrid", {"specialised": False}), ("hybrid", {"scalarize": True}),
    ("hybrid", {"duplicated": True, "radius_scale": 4.0}),
    *[("zbin", {"zbin_variant": v}) for v in (0, 1, 2)], ("zbin", {"printed_mask": True}),
    ("zbin", {"bit_tile": 3}), ("zbin", {"tile_depth": False, "zbin_variant": 2}),
    *[("fptl", {"fptl_variant": v}) for v in (1, 2, 3)], ("fptl", {"type_loops": False}),
    *[("raster", {"raster_variant": v}) for v in (1, 2)], ("raster", {"cluster": True}),
    ("raster", {"zbin_variant": 0}),
]
# The native wave path: waves of llvmpipe's subgroup (8 lanes) vote and scalarize.
NATIVE = [("clustered", {"scalarize": True}), ("hybrid", {}), ("hybrid", {"scalarize": True}),
          *[("zbin", {"zbin_variant": v}) for v in (1, 2, 3)], ("raster", {"zbin_variant": 3})]
NATIVE_WIDTH = 8


@pytest.mark.parametrize("scene", BUILTIN_SCENES)
def test_replay_matches_shader_counters_on_every_scene(gl, scene):
    sc = load_scene(scene, lights=LIGHTS, seed=3)
    with Renderer(sc, SIZE) as r:
        for name in REGISTRY:
            check(r, name, {}, 64, scene)


def test_replay_matches_shader_counters_in_every_variant(gl):
    sc = load_scene("corridor", lights=LIGHTS, seed=5)      # all four shapes, a glossy floor
    with Renderer(sc, SIZE) as r:
        for name, opts in VARIANTS:
            check(r, name, opts, 64, "corridor")


def test_native_path_at_subgroup_size_8(gl):
    """On llvmpipe the native path runs on 8-lane subgroups: the replay at width 8 gives the
    shader's counters (zbin's scalarized loop evaluates its 8-lane wave's union)."""
    from app.pipeline import gl as glmod
    assert glmod.limits().native_ballot, "llvmpipe should offer GL_ARB_shader_ballot"
    sc = load_scene("arena", lights=LIGHTS, seed=7)
    with Renderer(sc, SIZE) as r:
        for name, opts in NATIVE:
            check(r, name, dict(opts, native_wave=True), NATIVE_WIDTH, "arena")


def test_widths_change_only_what_they_should(gl):
    """A per-lane loop's work per pixel is the same at any width; its issued iterations lie
    between the 64-lane wave's and twice it (two 32-lane halves, each as long as its
    longest lane); a scalarized wave evaluates the union of its lanes' lights, so a narrower
    wave evaluates no more at any pixel."""
    sc = load_scene("city", lights=LIGHTS, seed=9)
    with Renderer(sc, SIZE) as r:
        for name, opts in (("clustered", {}), ("tree", {})):
            tech = REGISTRY[name]
            fr = waves.frame_data(r, r.render(tech, 0, opts), tech.resolve_options(opts))
            a, b = (waves.replay(parts.wave_program(tech, fr, w)) for w in (32, 64))
            assert np.array_equal(a.evaluated, b.evaluated) and np.array_equal(a.nodes, b.nodes)
            i32, i64 = a.figures.loops[:, 0].sum(), b.figures.loops[:, 0].sum()
            assert i64 <= i32 <= 2 * i64, (name, i32, i64)
            assert a.figures.waves == 2 * b.figures.waves
        tech = REGISTRY["zbin"]
        fr = waves.frame_data(r, r.render(tech, 0, {}), tech.resolve_options(None))
        a, b = (waves.replay(parts.wave_program(tech, fr, w)) for w in (32, 64))
        assert (a.evaluated <= b.evaluated).all() and a.evaluated.sum() < b.evaluated.sum()
        assert np.array_equal(a.contrib, b.contrib)


def list_lines(prog: waves.Program) -> tuple[int, dict[str, int]]:
    """The light loops' 64-byte lines counted from the program's segments alone (numpy, no
    tree segments): per issued iteration (a (wave, branch, step) group's t-th) the distinct
    lines of the entries and lights its lanes fetch, summed; and the bytes of each buffer's
    distinct lines over the frame."""
    seg, calls = prog.segments()
    assert not calls[:, 7].any(), "tree traversals: their leaves' lists are the replay's walk"
    group = (prog.wave[seg["lane"]] * 4 + calls[seg["call"], 0]) << 24 | seg["step"]
    lid, rows = calls[seg["call"], 5], []
    for k in np.unique(lid[(lid >= 0) & (seg["count"] > 0)]):
        sel = np.nonzero((lid == k) & (seg["count"] > 0))[0]
        n = seg["count"][sel]
        s = np.repeat(sel, n)
        t = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)      # the iteration
        L = prog.lists[k]
        p = seg["first"][s] + t
        e = L.entry_off[p] >= 0
        rows.append(np.stack([group[s][e], t[e], np.full(e.sum(), L.entry_buf), L.entry_off[p][e] // 64], 1))
        off = L.slot[p] * waves.LIGHT_BYTES
        for d in range(3):                                  # a light's lines (96 B: at most 3)
            line = off // 64 + d
            m = line <= (off + waves.LIGHT_BYTES - 1) // 64
            rows.append(np.stack([group[s][m], t[m], np.full(m.sum(), L.light_buf), line[m]], 1))
    rows = np.concatenate(rows)
    names = list(prog.buffers)
    lines = np.unique(rows[:, 2:], axis=0)
    return len(np.unique(rows, axis=0)), {names[b]: int((lines[:, 0] == b).sum()) * 64
                                          for b in np.unique(lines[:, 0])}


def assert_list_lines(prog: waves.Program, f: waves.Figures, what: str) -> None:
    """The replay's light-loop lines (its line set) and unique bytes equal list_lines'
    (the list loops' and evaluate_all_lights' mask loop's together)."""
    light = {k: f.loop("light")[k] + f.loop("mask_light")[k] for k in waves.FIELDS}
    per_iteration, unique = list_lines(prog)
    assert light["vector_lines"] + light["scalar_lines"] == per_iteration, (what, light, per_iteration)
    heads = {list(prog.buffers)[b] for b in prog.segments()[1][:, 2] if b >= 0}
    for name, nbytes in unique.items():
        if name not in heads:                                       # read by the light loops only
            assert f.unique_bytes[name] == nbytes, (what, name, f.unique_bytes[name], nbytes)


def test_figures_count_what_the_loops_do(gl):
    """brute: one scalar load of each light per busy wave, every shading lane active; a
    list technique's light iterations are its longest lanes', its vector loads two each;
    the light loops' distinct lines per iteration and per frame are list_lines' count."""
    sc = load_scene("arena", lights=256, seed=1)
    with Renderer(sc, SIZE) as r:
        res = r.render(REGISTRY["brute"], 0)
        fr = waves.frame_data(r, res, REGISTRY["brute"].resolve_options(None))
        prog = parts.wave_program(REGISTRY["brute"], fr, 64)
        f = waves.replay(prog).figures
        assert_list_lines(prog, f, "brute")
        n = len(res.build.lights)
        light = f.loop("mask_light")               # evaluate_all_lights: the mask loop alone
        assert f.loop("light")["issued"] == 0
        assert light["issued"] == n * f.busy_waves
        assert light["lanes"] == int(fr.shading.sum()) * n
        assert light["scalar_loads"] == light["issued"] and light["vector_loads"] == 0
        assert light["scalar_lines"] == 2 * light["issued"]         # a 96-B light: two lines
        assert f.unique_bytes["lights"] == -(-n * 96 // 64) * 64
        assert_set_bit_loop(f, res, r, sc, SIZE)
        res = r.render(REGISTRY["clustered"], 0)
        fr = waves.frame_data(r, res, REGISTRY["clustered"].resolve_options(None))
        prog = parts.wave_program(REGISTRY["clustered"], fr, 64)
        f = waves.replay(prog).figures
        assert_list_lines(prog, f, "clustered")
        ev = gl_order(res.evaluated)
        per_wave = np.zeros(f.waves, np.int64)
        wave, _, _ = waves.lanes(SIZE, 64)
        np.maximum.at(per_wave, wave, ev)
        assert f.loop("light")["issued"] == per_wave.sum()
        assert f.loop("light")["lanes"] == ev.sum()
        assert f.loop("light")["vector_loads"] == 2 * per_wave.sum()    # entry, then light
        assert f.loop("cell")["issued"] == f.busy_waves
        for opts in ({"scalarize": True}, {"duplicated": True}):      # scalar lists; one list a lane
            tech = REGISTRY["clustered"]
            fr = waves.frame_data(r, r.render(tech, 0, opts), tech.resolve_options(opts))
            for width in (32, 64):
                prog = parts.wave_program(tech, fr, width)
                assert_list_lines(prog, waves.replay(prog).figures, f"clustered {opts} W={width}")


def assert_set_bit_loop(f, res, renderer, scene, size) -> None:
    """brute's set-bit loop (pixel.glsl evaluate_all_lights): per wave and run of 32 lights,
    as many iterations as its busiest lane has affecting lights there, one lane-iteration per
    affecting light, a vector load each; counted here from the float64 light model."""
    _, _, near, inside = pixel_oracle(renderer, scene.lights, scene.camera)
    assert not near.any(), "a pixel on a volume's boundary: the float32 test may differ"
    h, w = inside.shape[0] // size[0], size[0]
    inside = inside.reshape(h, w, -1)[::-1].reshape(h * w, -1)[:, res.build.lights.ids]
    runs = -(-inside.shape[1] // waves.RUN)
    pad = np.zeros((len(inside), runs * waves.RUN), np.int64)
    pad[:, :inside.shape[1]] = inside
    hits = pad.reshape(len(inside), runs, waves.RUN).sum(2)          # (pixels, runs)
    wave, _, n_waves = waves.lanes(size, f.width)
    busiest = np.zeros((n_waves, runs), np.int64)
    np.maximum.at(busiest, wave, hits)
    got = f.loop("set_bit")
    assert inside.sum() > 0 and busiest.sum() < inside.sum()
    assert got["issued"] == busiest.sum() and got["lanes"] == inside.sum()
    assert got["vector_loads"] == got["issued"] and got["scalar_loads"] == 0
    assert int(f.shaded.sum()) == got["issued"]                     # one shape in the arena


def test_culling_pass_figures(gl):
    """tiled's tile_cull tests every light in every covered tile twice; fptl's lists prune
    each tile's coarse lights; raster's proxies draw its counted fragments."""
    sc = load_scene("arena", lights=512, seed=2)
    with Renderer(sc, SIZE) as r:
        for name in ("tiled", "fptl", "raster"):
            tech = REGISTRY[name]
            res = r.render(tech, 0)
            figs = predict.frame_figures(r, tech, res)
            for width, passes in figs.items():
                timed = [k for k in res.meta["gpu_ms"] if k != "gbuffer"]
                assert set(passes) - {predict.SHADE} <= {t.split(" (")[0] for t in timed} | \
                    {"raster proxies"}, (name, passes.keys(), timed)
                for f in passes.values():
                    assert f.loops[:, 0].sum() > 0
        n = len(res.build.lights)
        tech = REGISTRY["tiled"]
        res = r.render(tech, 0)
        f = predict.frame_figures(r, tech, res)[64]["tile_cull"]
        pixels, covered, tx, ty = waves.per_tile(waves.frame_data(r, res, tech.resolve_options(None)),
                                                 res.build.grid.tile)
        busy = int((covered > 0).sum())
        assert f.loop("cull_test")["lanes"] == 2 * busy * n


def test_cells_only_frames_replay_like_shaded_ones(gl):
    """A frame rendered with CELLS_ONLY (the benchmark's modelled 1080p runs) records the same
    cells, so its replay equals the shaded frame's, while its light loops did not run."""
    sc = load_scene("hangar", lights=LIGHTS, seed=4)
    with Renderer(sc, SIZE) as r:
        for name in REGISTRY:
            tech = REGISTRY[name]
            full = r.render(tech, 0)
            a = waves.replay(parts.wave_program(tech, waves.frame_data(r, full, tech.resolve_options(None)), 32))
            cells = r.render(tech, 0, defines={"CELLS_ONLY": 1})
            assert np.array_equal(cells.cell, full.cell), name
            assert int(cells.evaluated.sum()) == 0, f"{name}: CELLS_ONLY still shaded"
            b = waves.replay(parts.wave_program(tech, waves.frame_data(r, cells, tech.resolve_options(None)), 32))
            assert np.array_equal(a.evaluated, b.evaluated), name
            assert np.array_equal(a.figures.loops, b.figures.loops), name


def test_a_sampled_replay_stands_for_the_whole_frame(gl):
    """Every k-th group replayed and scaled (the benchmark's heavy and 1080p rows): close to
    the whole replay, and the groups left out add nothing (not even a scalarized loop's
    unguarded words)."""
    sc = load_scene("arena", lights=LIGHTS, seed=11)
    with Renderer(sc, (160, 96)) as r:
        for name, opts in (("clustered", {}), ("tree", {}), ("zbin", {"zbin_variant": 2})):
            tech = REGISTRY[name]
            res = r.render(tech, 0, opts)
            whole = predict.frame_figures(r, tech, res, opts)[64]["shade"]
            part = predict.frame_figures(r, tech, res, opts, sample=3)[64]["shade"]
            for k in range(len(waves.KINDS)):
                a, b = whole.loops[k, 0], part.loops[k, 0]
                assert abs(a - b) <= 0.25 * max(a, 1) + 2, (name, waves.KINDS[k], a, b)
            assert part.busy_waves == pytest.approx(whole.busy_waves, rel=0.25)


def test_a_sampled_replay_keeps_a_lattice_of_groups_not_columns():
    """sampled(every): one group in every `every` of each row of groups, and of each column
    where `every` divides the rows; every k-th group in dispatch order would keep whole
    columns where `every` divides a row's groups (stripes)."""
    w, h, every = 40 * 8, 32 * 8, 8                  # 40 groups a row: 8 divides it
    pos = np.ones((w * h, 4), np.float32)
    frame = waves.FrameData(build=None, opts=None, read=None, size=(w, h), position=pos,
                            specular=np.zeros(w * h, bool), cell=np.zeros(w * h, np.uint32))
    part, share = waves.sampled(frame, every)
    kept = part.live.reshape(h, w)[::8, ::8]          # a group's first pixel stands for it
    assert (kept.sum(1) == 40 // every).all() and (kept.sum(0) == 32 // every).all()
    assert share == pytest.approx(1 / every)
    assert (part.position[~part.live, 3] == 0).all() and (part.position[part.live, 3] > 0).all()
    assert waves.sampled(frame, 1) == (frame, 1.0)
