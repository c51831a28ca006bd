"""The flat bit arrays (Drobot 2017) and the loop that shades them, glsl/shade_zbin.comp,
written once for the two techniques that shade with it: zbin over its CPU (or depth-tested)
tiles, raster's tile mode over its rasterized ones (zbin.py's doc: the layout, the four
variants, the departures; glsl/zbin_mask.glsl: the word masks).

    ShadingOptions   the loop's options (zbin_variant, zbins, bit_tile, budget, printed_mask)
    attach_zbins     the Z-bin LUT of the build's sorted lights
    shading_steps    the shading pass over a bit-array buffer, then the wave counters
    add_bit_words    the loop for the wave replay (app.model.waves)
    tile_bit_maps    the lights a tile's bits (and a pixel's z-bin) hold, for the maps
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cpu_prep import layouts, limits, zbin as zb

from ..pipeline.passes import WAVE_STATS, HostStep
from .base import grid_uniforms, shading_passes
from .replay_walks import cell_head
from .options import WaveOptions, choice, option

VARIANTS = ("base tile", "tile + zbin", "scalarized tile", "scalarized tile + zbin")
DEFAULT_ZBINS = 8096          # the slides' figure at 1080p
DEFAULT_BIT_TILE = 8          # the slides' 8x8 pixel tiles


def attach_zbins(b, zbins: int, max_depth: float) -> None:
    """Drobot's Z-bins over the build's depth-sorted lights: the look-up table into
    b.buffers["zbins"] and its depth scale into b.bin_scale (zbin and raster)."""
    with b.times.stage("bin"):
        lut, scale = zb.zbin_lut(b.lights.depth_lo, b.lights.depth_hi, zbins, max_depth)
    b.buffers["zbins"] = lut
    b.bin_scale = float(scale)


def variant_flags(variant: int) -> tuple[bool, bool]:
    """(z-bin masked, scalarized) of a `zbin_variant`."""
    return bool(variant & 1), bool(variant & 2)


@dataclass(frozen=True)
class ShadingOptions(WaveOptions):
    """The options of shade_zbin.comp's loop (zbin's and raster's)."""
    zbin_variant: int = choice("scalarized tile + zbin", VARIANTS, "the slides' optimization table",
                               study=True)
    zbins: int = option(DEFAULT_ZBINS, "uniform Z bins over [0, max depth] (Drobot: 8096 at 1080p)",
                        lo=1, hi=1 << 20)
    bit_tile: int = option(DEFAULT_BIT_TILE, "tile of the flat bit arrays in pixels, before "
                                             "the memory budget doubles it", lo=1, hi=4096)
    bit_budget_mib: float = option(32.0, "memory budget of the tile bit arrays (MiB): the tile "
                                         "doubles until they fit (Unity URP Forward+)",
                                   lo=1 / 64, hi=limits.MAX_STORAGE_BYTES / 2**20)
    printed_mask: bool = option(False, "the slides' Z-bin word mask as printed: it leaks bit 31 "
                                       "of earlier words, the tail of the last, and whole words "
                                       "(the first's head too) once the range is 32 or wider "
                                       "(more evaluations, still exact)", study=(False, True))

    @property
    def budget_bytes(self) -> int:
        """bit_budget_mib in bytes: cpu_prep.zbin.choose_tile's budget."""
        return int(self.bit_budget_mib * 2**20)

    def ignored(self) -> dict[str, str]:
        """What shade_zbin.comp's variant does not read (options.py's rule): without z-bins
        (variants 0, 2) neither their count nor their mask; the base tile (0) no wave op."""
        masked, scalarized = variant_flags(self.zbin_variant)
        out = dict(super().ignored())
        mode = f"without z-bins (--zbin-variant {self.zbin_variant})"
        if not masked:
            out.update(zbins=mode, printed_mask=mode)
        if not masked and not scalarized:
            out["native_wave"] = "in the base tile (--zbin-variant 0: no wave operation)"
        return out


TILE_UNIFORMS = ("u_tile", "u_tiles")   # grid_uniforms' 2D part: what shade_zbin.comp declares


def tile_uniforms(grid) -> dict:
    """The tile grid's uniforms (base.grid_uniforms) without its depth slices."""
    return {k: v for k, v in grid_uniforms(grid).items() if k in TILE_UNIFORMS}


def shading_steps(build, opts: ShadingOptions, bits: str) -> list:
    """shade_zbin.comp's loop over the tile bit arrays in buffer `bits`, then the untimed
    wave counters: zbin's shading (its CPU or depth-tested tiles) and raster's tile mode
    (its rasterized tiles), one builder for both."""
    masked, scalarized = variant_flags(opts.zbin_variant)
    g, n = build.grid, len(build.lights)
    wide = zb.is_wide(n)
    shade = shading_passes(
        build, "shade_zbin.comp", ("tile_bits",) + (("zbins",) if masked else ()), longest=n,
        defines={"ZBIN_MASKED": int(masked), "SCALARIZED": int(scalarized),
                 "ZBIN_WIDE": int(wide), "ZBIN_PRINTED_MASK": int(opts.printed_mask),
                 "ZBIN_EMPTY_MIN": zb.ZBIN_WIDE_EMPTY_MIN if wide else zb.ZBIN_NARROW_EMPTY},
        uniforms=dict(tile_uniforms(g), u_words=zb.words_for(n), u_bins=opts.zbins,
                      u_bin_scale=build.bin_scale),
        native_wave=opts.native_wave, sources={"tile_bits": bits})
    return shade + [HostStep("wave counters", (WAVE_STATS,),
                             lambda got: wave_counters(build, got[WAVE_STATS]), figures=True)]


def wave_counters(build, waves: np.ndarray):
    """Meta stats from the shading pass's wave statistics (untimed, after the frame): the
    waves' loop iterations against the per-lane loops' (module doc of shade_zbin.comp)."""
    waves = waves.view(layouts.WAVE_STATS)
    build.stats.update(
        wave_iterations=int(waves["iterations"].sum(dtype=np.int64)),
        lane_iterations=int(waves["lane_loops"][:, 0].sum(dtype=np.int64)),
        lane_max_iterations=int(waves["lane_loops"][:, 1].sum(dtype=np.int64)),
        waves_active=int((waves["lane_loops"][:, 0] > 0).sum()))
    return {}, []


def add_bit_words(prog, bits_buf: str, grid, masked: bool, scalarized: bool, printed: bool,
                  cluster: bool = False) -> None:
    """shade_zbin.comp's loop for the wave replay (app.model.waves.Program.bit_words): each
    pixel's tile word offset, its z-bin's record (out_cell: the bin) and id range; or, for
    the cluster rasterizer's loop (`cluster`), its cluster's words (out_cell: the cluster)."""
    fr = prog.frame
    words = zb.words_for(len(fr.build.lights))
    x, y = fr.pixel_xy
    address = ((y // grid.tile) * grid.tiles_x + x // grid.tile) * words
    lo = np.zeros(len(x), np.int64)
    hi = np.full(len(x), 0xFFFFFFFF, np.int64)
    if cluster:
        address = fr.cell * words
    elif masked:
        lut = fr.build.buffers["zbins"]
        lanes = np.nonzero(fr.shading)[0]
        prog.add(lanes, head=cell_head(prog, lanes, "zbins", np.dtype((np.uint32, lut.shape[1:]))))
        zlo, zhi = zb.unpack_lut(lut)
        lo, hi = zlo[fr.cell], zhi[fr.cell]
    prog.bit_words(address, lo, hi, bits_buf, words, masked, scalarized, printed)


def tile_bit_maps(tile_bits, grid, depth=None, lut=None, bin_scale=0.0) -> dict:
    """{"tile_lights": per tile (image order) the lights its bit array holds; with a z-bin
    LUT, "zbin_lights": per pixel the lights of its z-bin range (0 on the sky)}."""
    words = np.ascontiguousarray(tile_bits).view(np.uint32).reshape(grid.tiles_y, grid.tiles_x, -1)
    per_tile = np.unpackbits(words.view(np.uint8), axis=-1).sum(-1, dtype=np.int64)
    out = {"tile_lights": (per_tile[::-1], "lights / tile (bits)")}
    if lut is not None and depth is not None:
        lo, hi = zb.unpack_lut(lut)
        b = np.minimum(np.floor(depth.astype(np.float32) * np.float32(bin_scale)), len(lo) - 1)
        b = b.astype(np.int64)
        count = np.where(hi[b] >= lo[b], hi[b] - lo[b] + 1, 0)
        out["zbin_lights"] = (np.where(depth > 0, count, 0), "lights / z-bin range")
    return out


__all__ = ["VARIANTS", "ShadingOptions", "attach_zbins", "variant_flags", "shading_steps",
           "wave_counters", "tile_uniforms", "add_bit_words", "tile_bit_maps"]
