"""Fog on the command line and in the exactness check (the frame side: app/pipeline/fog.py).

    --froxels WxHxD | matched    the froxel grid (default 160x90x64; matched: a froxel per
                                 cell of a cell technique's own grid)
    --froxel-samples 1 | 8       points a froxel is lit at (its centre; its octants' centres)
    --froxel-lookup exact | centre   exact light sets (default), or each froxel's centre
                                 cell's list unchecked: the shortcut, for showing its banding

A scene without fog takes none of them (one line, exit 2).  The check: a fog frame's
froxel_count and froxel_hash must equal the reference's at every froxel.
"""
from __future__ import annotations

import numpy as np

from cpu_prep import froxels as fx

from .errors import UserError
from .pipeline.fog import FROXEL_SOURCES, LOOKUPS, SAMPLES, FogOptions, source_of

FLAGS = ("froxels", "froxel_samples", "froxel_depth", "froxel_lookup")


def parse_froxels(text: str):
    if text == "matched":
        return text
    try:
        dims = tuple(int(v) for v in text.lower().split("x"))
    except ValueError:
        dims = ()
    if len(dims) != 3:
        raise UserError(f"--froxels {text}: expected WxHxD (e.g. 160x90x64) or 'matched'")
    return dims


def add_fog_args(p) -> None:
    g = p.add_argument_group("fog (a scene with a `fog` block)")
    w, h, d = fx.DEFAULT_FROXELS
    g.add_argument("--froxels", default=None, metavar="WxHxD",
                   help=f"froxel grid, depth exponential from near to fog.far (default "
                        f"{w}x{h}x{d}, W and H at most the image's; 'matched': a froxel per cell of the technique's own "
                        f"grid); at most {fx.MAX_FROXELS:,} froxels")
    g.add_argument("--froxel-samples", type=int, choices=SAMPLES, default=None,
                   help="points a froxel is lit at: 1 its centre (default), 8 its octants' centres")
    g.add_argument("--froxel-depth", choices=fx.DEPTHS, default=None,
                   help="the slices' depth distribution from near to fog.far: exponential "
                        "(default; each slice the same ratio deep) or linear (not with "
                        "--froxels matched, whose slices are the technique's)")
    g.add_argument("--froxel-lookup", choices=LOOKUPS, default=None,
                   help="exact: each froxel's exact light set (default); centre: the list of "
                        "the cell its centre falls in, unchecked (not exact: the banding case)")


def fog_options(args, scene) -> FogOptions | None:
    """The FogOptions of a command line (None: the defaults), refused in one line on a scene
    without fog or for a grid past its limits."""
    given = [f for f in FLAGS if getattr(args, f, None) is not None]
    if scene.fog is None:
        if given:
            raise UserError(f"--{given[0].replace('_', '-')}: the scene has no fog (a scene "
                            f"file's `fog` block, or the builtin variant hangar-fog)")
        return None
    if not given:
        return None
    froxels = parse_froxels(args.froxels) if args.froxels is not None else None
    if isinstance(froxels, tuple):                 # refused before anything renders
        w, h = getattr(args, "size", None) or scene.resolution
        try:
            fx.check_dims(froxels, w, h)
        except fx.FroxelError as exc:
            raise UserError(str(exc)) from None
    depth = getattr(args, "froxel_depth", None)
    if depth is not None and froxels == "matched":
        raise UserError("--froxel-depth: --froxels matched takes the technique's own slices")
    return FogOptions(froxels, args.froxel_samples or 1, args.froxel_lookup or "exact",
                      depth or "exponential")


def reference_options(result, options: FogOptions | None) -> FogOptions | None:
    """The fog options the reference is rendered with to check `result`: its froxel grid,
    exact sets (a frame of another lookup is held to the exact ones)."""
    if result.froxel_grid is None:
        return options
    return FogOptions(result.froxel_grid, (options or FogOptions()).samples, "exact")


def check_froxels(result, reference) -> str | None:
    """One line where the froxel light sets differ from the reference's, else None."""
    got, want = result.froxel_count, reference.froxel_count
    if got is None and want is None:
        return None
    if got is None or want is None or got.shape != want.shape:
        return (f"froxels: {result.meta.get('technique')} and {reference.meta.get('technique')} "
                f"have different froxel grids")
    bad = (got != want) | (result.froxel_hash != reference.froxel_hash)
    if not bad.any():
        return None
    k, row, i = (int(v) for v in np.argwhere(bad)[0])
    return (f"froxels: {result.meta.get('technique')} differs from "
            f"{reference.meta.get('technique')} at {int(bad.sum())} of {bad.size} froxels; "
            f"first at slice {k}, row {row}, column {i} (count {int(got[k, row, i])} vs "
            f"{int(want[k, row, i])})")


def serves_line(technique) -> str:
    """docs/techniques.md's line of how `technique` serves a fog scene's froxels."""
    from .techniques import REGISTRY
    src = source_of(technique)
    if src is None:
        serving = ", ".join(t.name for t in REGISTRY.values() if source_of(t) is not None)
        return (f"- Fog: does not serve froxels; a fog scene is refused in one line and exit 2 "
                f"(those that serve them: {serving})")
    return f"- Fog: serves froxels from `{src}`: {FROXEL_SOURCES[src]}"
