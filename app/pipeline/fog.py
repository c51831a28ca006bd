"""Volumetric fog: a scene's homogeneous medium (scenes.model.Fog) lit over a froxel grid
from each technique's own structure, after the technique's frame (Renderer.render).

    froxel sets (CPU, cpu_prep/froxels.py): each froxel's lights, from the technique's
        candidates (its declared `froxels`: "all" every visible light, brute; "cells" the
        union of the lists of its 2.5D cells the froxel overlaps, clustered; "trees" the
        leaves of the cells' light trees whose depth interval overlaps the froxel's, tree
        and hybrid), kept by the exact test ("meets": cpu_prep/froxels.py)
    fog_light     (compute) each froxel's in-scatter from its set at FROXEL_SAMPLES points,
                  Henyey-Greenstein phase; its count and hash of the set
    fog_march     (compute) scattering and transmittance integrated along each column
    fog_composite (compute) out_color = colour * T + S at each pixel's depth

A technique declares how it serves froxels by its class attribute `froxels` ("all",
"cells", "trees"; None: it refuses a fog scene in one line); FROXEL_SOURCES says what each means.
The frame's stats add the grid and, per froxel on average, the lights it meets, the
candidates it was given, and those it did not need; a cell technique also the same figure on
the matched grid (one froxel per cell of its own grid), which is what a grid of its own
slices would give.  `lookup="centre"` replaces a cell technique's exact sets by the list of
the cell each froxel's centre falls in, unchecked: the shortcut whose banding the exact sets
avoid, not exact by design (its stats say so).
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
import hashlib
import time

import numpy as np

from cpu_prep import froxels as fx, layouts
from cpu_prep.limits import check_buffer

from ..errors import UserError
from . import features as feat
from .passes import OUT_COLOR, Buffer, Pass

FROXEL_SOURCES = {
    "all": "every visible light is a candidate of every froxel; the exact test keeps those "
           "that meet it",
    "cells": "a froxel's candidates are the union of the lists of the 2.5D cells of its grid "
             "that the froxel overlaps (cpu_prep/froxels.py); the exact test keeps those "
             "that meet it",
    "trees": "a froxel's candidates are the lights of the leaves, among the light trees of the "
             "cells it overlaps, whose bounding depth interval overlaps the froxel's depths "
             "(cpu_prep/froxels.py tree_spans); the exact test keeps those that meet it",
}
CELL_SOURCES = ("cells", "trees")     # a grid of cells: the matched grid is theirs
SAMPLES = (1, 8)
LOOKUPS = ("exact", "centre")
FROXEL_STATS = np.dtype([("count", np.uint32), ("hash", np.uint32)])


@dataclass(frozen=True)
class FogOptions:
    """The froxel grid: (W, H, D), "matched" (a cell technique's own grid) or a FroxelGrid
    (another frame's, e.g. the one the reference is held to), the samples a froxel is lit at
    (1 its centre, 8 its octants' centres) and the lookup (exact sets, or the centre-cell
    shortcut)."""
    froxels: tuple[int, int, int] | str | fx.FroxelGrid | None = None   # None: the default
    samples: int = 1
    lookup: str = "exact"
    depth: str = "exponential"      # the slices' depth distribution (cpu_prep.froxels.DEPTHS)

    def as_dict(self) -> dict:
        dims = self.froxels.dims if isinstance(self.froxels, fx.FroxelGrid) else \
            (self.froxels or "default")
        f = dims if isinstance(dims, str) else "x".join(map(str, dims))
        return {"froxels": f, "samples": self.samples, "lookup": self.lookup, "depth": self.depth}


def source_of(technique) -> str | None:
    return getattr(technique, "froxels", None)


def refusal(technique, opts, fog_opts: FogOptions | None = None) -> str | None:
    """Why `technique` with `opts` cannot serve a fog scene's froxels (one line), else None."""
    src = source_of(technique)
    if src is None:
        return (f"{technique.name} does not serve froxels, so it cannot render a fog scene "
                f"(docs/techniques.md, each technique's 'Fog' line: those that do)")
    for name in ("build", "stochastic", "cap_policy"):     # each 0 at its default (cpu, off, none)
        if getattr(opts, name, 0):
            flag = "--" + name.replace("_", "-")
            return (f"{technique.name}: {flag} with a fog scene: the froxel sets are built from "
                    f"the CPU stage's exact lights (leave {flag} at its default)")
    fo = fog_opts or FogOptions()
    if src not in CELL_SOURCES and isinstance(fo.froxels, str):
        return (f"{technique.name}: --froxels {fo.froxels} needs a technique whose froxels "
                f"come from a grid of cells (its froxels: {src})")
    if src != "cells" and fo.lookup != "exact":
        return (f"{technique.name}: --froxel-lookup {fo.lookup} needs a technique whose "
                f"froxels come from cell lists (its froxels: {src})")
    return None


def refuse(technique, opts, fog_opts: FogOptions | None = None) -> None:
    """refusal() as a UserError, before the frame."""
    why = refusal(technique, opts, fog_opts)
    if why:
        raise UserError(why)


def froxel_grid(build, fog, fo: FogOptions) -> fx.FroxelGrid:
    cam = build.frame.camera
    if isinstance(fo.froxels, fx.FroxelGrid):
        if (fo.froxels.width, fo.froxels.height) != (cam.width, cam.height):
            raise UserError("fog: the given froxel grid is for another image size")
        return fo.froxels
    try:
        if fo.froxels == "matched":
            return fx.matched_grid(cam, build.grid, fog.far)
        return fx.make_froxel_grid(cam, fo.froxels or fx.default_dims(cam.width, cam.height),
                                   fog.far, fo.depth)
    except fx.FroxelError as exc:
        raise UserError(str(exc)) from None


def cell_lists(build):
    """(ranges (cells, 2) int64, entries) of a cell technique's CPU-built CSR lists."""
    ranges = build.buffers["ranges"]["offset_count"].astype(np.int64)
    return ranges, build.buffers["entries"]


def from_cells(technique, build, fg: fx.FroxelGrid, lb) -> fx.FroxelSets:
    """The exact sets of a technique of cells: its lists, or its trees' leaves."""
    if source_of(technique) == "trees":
        spans = fx.tree_spans(build.buffers["ranges"]["offset_count"], build.buffers["nodes"])
        return fx.froxel_sets_from_spans(fg, build.grid, *spans, build.buffers["entries"], lb)
    return fx.froxel_sets_from_cells(fg, build.grid, *cell_lists(build), lb)


def froxel_sets(technique, build, fg: fx.FroxelGrid, lb, lookup: str = "exact") -> fx.FroxelSets:
    """The froxels' light sets from `technique`'s own structure (its declared source)."""
    src = source_of(technique)
    if src == "all":
        return fx.froxel_sets_all(fg, lb)
    if lookup == "centre":
        return fx.centre_cell_sets(fg, build.grid, *cell_lists(build))
    return from_cells(technique, build, fg, lb)


def sets_key(technique, build, fg: fx.FroxelGrid, lb, lookup: str = "exact") -> bytes:
    """A digest of everything a frame's froxel sets depend on: the technique's source and the
    lookup, the froxel grid, the lights' bounds (LightBounds: what "meets" reads) and, for a
    technique of cells, its grid and the lists (or trees) the candidates come from.  Two
    frames whose camera and lights did not change give the same key."""
    h = hashlib.blake2b(digest_size=20)
    src = source_of(technique)
    h.update(f"{src}|{lookup}|{fg.width}x{fg.height}|{fg.tan_x!r}|{fg.tan_y!r}".encode())
    arrays = [fg.xs, fg.ys, fg.zs, lb.centre, lb.radius, lb.rect, lb.depth]
    if src in CELL_SOURCES:
        g = build.grid
        h.update(repr((g.width, g.height, g.tile, g.slices, g.log_min, g.log_max)).encode())
        arrays += [fx.slice_edges(g), build.buffers["ranges"], build.buffers["entries"]]
        if src == "trees":
            arrays.append(build.buffers["nodes"])
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.view(np.uint8).reshape(-1) if a.size else b"")
    return h.digest()


class FroxelSetCache:
    """The last few frames' froxel sets by sets_key(): a frame whose camera and lights did
    not change (a still window) takes its sets from here instead of building them again.
    Opt-in: a renderer with `froxel_cache` set to one uses it (render_fog); capture and the
    benchmark leave it unset, so each frame's cpu_ms.froxels is a build."""

    def __init__(self, size: int = 4):
        self.size = max(1, int(size))
        self._sets: OrderedDict[bytes, fx.FroxelSets] = OrderedDict()
        self.hits = 0
        self.misses = 0

    def get(self, key: bytes, build_sets):
        """The sets of `key`, from build_sets() the first time.  -> (sets, reused)."""
        sets = self._sets.get(key)
        if sets is not None:
            self._sets.move_to_end(key)
            self.hits += 1
            return sets, True
        sets = build_sets()
        self.misses += 1
        self._sets[key] = sets
        while len(self._sets) > self.size:
            self._sets.popitem(last=False)
        return sets, False

    def clear(self) -> None:
        self._sets.clear()


def cached_sets(cache: FroxelSetCache | None, technique, build, fg: fx.FroxelGrid, lb,
                lookup: str = "exact"):
    """froxel_sets(), through `cache` where there is one.  -> (sets, reused)."""
    make = lambda: froxel_sets(technique, build, fg, lb, lookup)
    if cache is None:
        return make(), False
    return cache.get(sets_key(technique, build, fg, lb, lookup), make)


def edges_array(fg: fx.FroxelGrid) -> np.ndarray:
    us, vs = fg.ndc()
    return np.concatenate([fg.xs, fg.ys, fg.zs, us, vs]).astype(np.float32)


def passes(fg: fx.FroxelGrid, fog, fo: FogOptions, size) -> list[Pass]:
    w, h, d = fg.dims
    n = fg.count
    common = {"u_froxels": (w, h, d), "u_tan": (float(fg.tan_x), float(fg.tan_y))}
    groups = (-(-w // 8), -(-h // 8), 1)
    albedo = np.asarray(fog.albedo, np.float64)
    return [
        Pass("fog_light", "fog_light.comp",
             reads=("lights", "froxel_ranges", "froxel_entries", "froxel_edges"),
             writes={"froxel_light": Buffer(16 * n, np.dtype((np.float32, 4))),
                     "froxel_stats": Buffer(8 * n, FROXEL_STATS)},
             groups=(groups[0], groups[1], d), defines={"FROXEL_SAMPLES": fo.samples},
             uniforms=dict(common, u_scattering=tuple(float(x) for x in albedo * fog.density),
                           u_anisotropy=float(fog.anisotropy))),
        Pass("fog_march", "fog_march.comp", reads=("froxel_light", "froxel_edges"),
             writes={"froxel_accum": Buffer(16 * n, np.dtype((np.float32, 4)))},
             groups=groups, uniforms=dict(common, u_density=float(fog.density))),
        Pass("fog_composite", "fog_composite.comp",
             reads=("froxel_light", "froxel_accum", "froxel_edges"),
             writes={OUT_COLOR: Buffer(size[0] * size[1] * 16, np.dtype((np.float32, 4)))},
             groups=(-(-size[0] // 8), -(-size[1] // 8), 1),
             uniforms=dict(common, u_density=float(fog.density), u_size=tuple(size))),
    ]


def mean(total, n) -> float:
    return round(float(total) / max(int(n), 1), 4)


def render_fog(renderer, technique, opts, build, result, fo: FogOptions | None, readback: bool) -> None:
    """The fog of the frame just rendered: its froxel sets (CPU, timed as cpu_ms.froxels;
    a renderer whose `froxel_cache` is a FroxelSetCache takes a still frame's from there and
    says so in meta['fog']['froxel_sets_reused']),
    their upload and three passes (timed: gpu_ms.fog_*), the figures in meta['stats'] and
    meta['fog'], and, read back, result.froxel_count / froxel_hash (D, H, W), row 0 the top."""
    fog = renderer.scene.fog
    fo = fo or FogOptions()
    refuse(technique, opts, fo)
    fg = froxel_grid(build, fog, fo)
    t0 = time.perf_counter()
    lb = fx.light_bounds(build.lights)
    cache = getattr(renderer, "froxel_cache", None)
    sets, reused = cached_sets(cache, technique, build, fg, lb, fo.lookup)
    cpu_ms = (time.perf_counter() - t0) * 1e3
    longest = int(sets.counts().max(initial=0))
    budget = renderer.limits.loop_budget
    # fog_light's loops per invocation: the set's hash, then each sample's light loop
    if budget is not None and longest * (fo.samples + 1) + fo.samples > budget:
        raise UserError(f"fog: a froxel meets {longest} lights, which at {fo.samples} samples "
                        f"pass this driver's loop budget of {budget} iterations a froxel "
                        f"(fewer lights or smaller froxels)")
    ranges = np.zeros(fg.count, layouts.CELL_RANGE)
    ranges["offset_count"][:, 0] = sets.offsets[:-1]
    ranges["offset_count"][:, 1] = np.diff(sets.offsets)
    try:
        check_buffer("froxel light lists", 4 * len(sets.entries))
    except Exception as exc:
        raise UserError(str(exc)) from None
    t1 = time.perf_counter()
    renderer.upload("froxel_ranges", ranges)
    renderer.upload("froxel_entries", np.asarray(sets.entries, np.uint32))
    renderer.upload("froxel_edges", edges_array(fg))
    upload_ms = (time.perf_counter() - t1) * 1e3
    features = feat.feature_set(build.lights.type, False)
    renderer.timer.take()
    renderer.run(passes(fg, fog, fo, renderer.size), feat.virtual_files(features),
                 technique=technique.name)
    gpu_ms = renderer.timer.take()
    m = result.meta
    m["cpu_ms"] = dict(m["cpu_ms"], froxels=cpu_ms, froxel_upload=upload_ms)
    m["gpu_ms"] = dict(m["gpu_ms"], **gpu_ms)
    kept = len(sets.entries)
    w, h, d = fg.dims
    stats = {"froxels": f"{w}x{h}x{d}", "froxel_count_total": fg.count,
             "froxel_lights_mean": mean(kept, fg.count),
             "froxel_candidates_mean": mean(sets.candidates, fg.count),
             "froxel_unneeded_mean": mean(sets.candidates - kept, fg.count)}
    line = (f"froxels {w}x{h}x{d} ({fo.lookup}): {stats['froxel_lights_mean']:.3g} lights meet "
            f"a froxel on average; its candidates {stats['froxel_candidates_mean']:.3g}, "
            f"{stats['froxel_unneeded_mean']:.3g} of them not needed")
    if source_of(technique) in CELL_SOURCES and fo.lookup == "exact":
        mg = fx.matched_grid(build.frame.camera, build.grid, fog.far)
        ms, _ = cached_sets(cache, technique, build, mg, lb)
        mw, mh, md = mg.dims
        stats["froxels_matched"] = f"{mw}x{mh}x{md}"
        stats["froxel_unneeded_mean_matched"] = mean(ms.candidates - len(ms.entries), mg.count)
        line += (f"; on the matched grid ({mw}x{mh}x{md}, a froxel per cell) "
                 f"{stats['froxel_unneeded_mean_matched']:.3g}")
    if fo.lookup != "exact":
        stats["froxel_sets"] = "centre cell, not exact"
        line += "; the sets are each froxel's centre cell's list, unchecked (not exact)"
    m["stats"] = dict(m["stats"], **stats)
    m["fog"] = {"density": fog.density, "albedo": list(fog.albedo), "far": fog.far,
                "anisotropy": fog.anisotropy, "froxel_source": source_of(technique),
                **fo.as_dict(), "mismatch": line}
    if cache is not None:
        m["fog"]["froxel_sets_reused"] = reused
    if readback:
        raw = renderer.read("froxel_stats")
        flip = lambda a: a.reshape(d, h, w)[:, ::-1, :].copy()
        result.froxel_count = flip(raw["count"])
        result.froxel_hash = flip(raw["hash"])
        result.froxel_sets = sets
        result.froxel_grid = fg
