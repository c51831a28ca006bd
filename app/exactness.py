"""The exactness check of the dump contract, and what it shows when it fails.

A technique is exact when, at every pixel, its contrib_count and contrib_hash equal the
reference's (brute: role "reference").  When they do not, as Mitsuba's render tests do, the
check writes the technique's image, the reference's and a difference image (differing pixels
marked), and names the first differing pixel with the lights that differ there: both frames
are rendered again recording the ids of the lights their shading passes find affecting that
pixel (Renderer.render(debug_pixel=...), glsl/pixel.glsl DEBUG_PIXEL).

A frame a cap policy capped (meta stats cap_policy, capped_lights: cpu_prep.caps) is the one
case where a technique differs from the reference on purpose.  It is never a pass and never
a plain failure: the check renders the reference again with the dropped lights reaching
nothing (caps.without: the same ids), and the technique must equal that frame at every
pixel; then the result is an IntendedLoss, counted against the real reference (the pixels
whose light set differs, the lights dropped).  Where it does not, the Mismatch is against
that frame and names the lights missing or extra beyond the intended loss.

A per-tile cap (HDRP FPTL, hdrp-fptl-*: caps.per_tile) drops a light from some tiles and
keeps it in others, so no one reference frame holds it.  The check computes on the CPU what
each pixel must keep (app.tile_caps: the exact per-pixel lists of the floor technique,
themselves checked against the reference, less the (tile, light) entries caps.tile_keep
drops by HDRP's sort keys) and holds the frame to that at every pixel; the IntendedLoss then
also counts the tile list entries dropped and the tiles that dropped one.

A frame with stochastic light culling (options stochastic, stochastic_seed, stochastic_frame:
cpu_prep.stochastic) is exact against the reference rendered with the same draw: brute takes
those options, and the same budget, seed and frame give the same per-light ranges.  A
reference given with another draw (capture renders brute with its defaults) is rendered again
with the frame's draw when the renderer is given.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cpu_prep import caps

from .techniques.options import STOCHASTIC_NAMES

MARK = (255, 40, 40)          # differing pixels in the difference image
FIRST = (255, 230, 0)         # the first differing pixel


def differing(result, reference) -> np.ndarray:
    """(H, W) bool: pixels whose count or hash differs from the reference's."""
    return differing_figures(result.contrib_count, result.contrib_hash,
                             reference.contrib_count, reference.contrib_hash)


def differing_figures(count, hashes, want_count, want_hash) -> np.ndarray:
    """(H, W) bool: pixels whose (count, hash) differ from (want_count, want_hash)."""
    return (count != want_count) | (hashes != want_hash)


@dataclass
class Mismatch:
    technique: str
    reference: str
    pixels: int                        # pixels that differ
    total: int
    first: tuple[int, int]             # (x, row from the top)
    count: tuple[int, int]             # (technique's, reference's) count at the first pixel
    missing: list[int] = field(default_factory=list)   # light ids the technique lacks there
    extra: list[int] = field(default_factory=list)     # ids it has that the reference lacks
    images: dict[str, Path] = field(default_factory=dict)

    def message(self) -> str:
        x, row = self.first
        s = (f"{self.technique} differs from {self.reference} at {self.pixels} of {self.total} "
             f"pixels; first at x={x}, row={row} (count {self.count[0]} vs {self.count[1]})")
        if self.missing or self.extra:
            s += f": missing lights {_ids(self.missing)}, extra lights {_ids(self.extra)}"
        if self.images:
            s += "; images: " + ", ".join(str(p) for p in self.images.values())
        return s


@dataclass
class IntendedLoss:
    """A capped frame that equals the reference but for the lights its cap policy dropped."""
    technique: str
    reference: str
    policy: str
    pixels: int                        # pixels whose light set differs from the reference's
    total: int
    lights: int                        # lights the policy dropped from the frame (per tile:
                                       # from some tile)
    contributions: int                 # (pixel, light) pairs lost: the reference's count less ours
    entries: int | None = None         # per-tile caps: (tile, light) list entries dropped
    tiles: int | None = None           # ... tiles that dropped one

    def message(self) -> str:
        where = ("exact without the dropped lights" if self.entries is None else
                 f"per tile: {self.entries} list entries dropped in {self.tiles} tiles, exact "
                 f"but for them")
        return (f"intended loss: {self.pixels} pixels, {self.lights} lights dropped by "
                f"{self.policy} ({self.technique} against {self.reference}: {self.pixels} of "
                f"{self.total} pixels lose {self.contributions} light contributions; {where})")


def capped(result) -> tuple[str, int] | None:
    """(policy, lights dropped) of a frame a cap policy capped, else None."""
    stats = result.meta.get("stats") or {}
    policy = stats.get("cap_policy", caps.NONE)
    return None if policy == caps.NONE else (policy, int(stats.get("capped_lights", 0)))


def stochastic_draw(result) -> dict:
    """{option: value} of a frame's stochastic draw (budget, seed, frame); {} when off."""
    opts = result.meta.get("options") or {}
    return {k: opts[k] for k in STOCHASTIC_NAMES if k in opts} if opts.get("stochastic") else {}


def _ids(ids, most: int = 12) -> str:
    ids = list(ids)
    return "[" + ", ".join(map(str, ids[:most])) + (f", ... {len(ids)} in all" if len(ids) > most else "") + "]"


def check(result, reference, renderer=None, technique=None, reference_technique=None,
          render_args: dict | None = None, out_dir=None) -> Mismatch | IntendedLoss | None:
    """None when exact; else the Mismatch, explained with the lights that differ when the
    renderer and both techniques are given (render_args: frame, opts, lights, ... of the
    frame; opts are the technique's, the reference renders with its defaults but for the
    frame's stochastic draw, stochastic_draw()) and with
    images written to out_dir when given.  A capped frame (capped()) gives its IntendedLoss
    when it equals the reference without the dropped lights (that frame rendered with the
    renderer; without one, when no pixel has a light the reference lacks: a count above the
    reference's), else the Mismatch against that frame."""
    draw = stochastic_draw(result)
    if draw != stochastic_draw(reference) and renderer is not None and reference_technique is not None:
        args = {k: v for k, v in (render_args or {}).items() if k != "opts"}
        reference = renderer.render(reference_technique, opts=dict(draw), **args)
    cap = capped(result)
    if cap is not None:
        return _check_capped(result, reference, cap, renderer, technique, reference_technique,
                             render_args, out_dir)
    m = _compare(result, reference, renderer, technique, reference_technique, render_args,
                 out_dir)
    return m if m is not None else _layers_mismatch(result, reference, renderer, technique,
                                                    reference_technique, render_args, out_dir)


def _layers_mismatch(result, reference, renderer=None, technique=None, reference_technique=None,
                     render_args=None, out_dir=None) -> Mismatch | None:
    """check()'s part for the transparent layers (app/pipeline/transparent.py): every layer's
    count and hash equal to the reference's at every pixel, else the Mismatch naming the
    layer (and, given the renderer and both techniques, the lights that differ at its first
    pixel, both frames rendered again recording that layer's lights there)."""
    from .pipeline.transparent import layer_difference
    diff = layer_difference(result, reference)
    if diff is None:
        return None
    where, mask, counts = diff
    first = (0, 0) if mask is None else tuple(int(v) for v in np.argwhere(mask)[0][::-1])
    m = Mismatch(result.meta.get("technique", "?"),
                 f"{reference.meta.get('technique', '?')} on its {where}",
                 1 if mask is None else int(mask.sum()), 1 if mask is None else int(mask.size),
                 first, counts)
    layers = getattr(renderer, "transparent", None)
    if mask is not None and layers is not None and technique is not None and reference_technique is not None:
        layers.debug_layer = int(where.rsplit(" ", 1)[1])
        try:
            args = dict(render_args or {})
            got = renderer.render(technique, readback=False, debug_pixel=first, **args).debug_lights
            args["opts"] = stochastic_draw(result) or None
            want = renderer.render(reference_technique, readback=False, debug_pixel=first,
                                   **args).debug_lights
        finally:
            layers.debug_layer = None
        m.missing = sorted(set(want.tolist()) - set(got.tolist()))
        m.extra = sorted(set(got.tolist()) - set(want.tolist()))
    if mask is not None and out_dir is not None:     # the composites, the layer's pixels marked
        m.images = write_images(Path(out_dir), result, reference, mask, first)
    return m


def _compare(result, reference, renderer, technique, reference_technique, render_args,
             out_dir) -> Mismatch | None:
    """check() of a frame that should equal `reference` at every pixel."""
    mask = differing(result, reference)
    if not mask.any():
        return None
    row, x = (int(v) for v in np.argwhere(mask)[0])
    m = Mismatch(result.meta.get("technique", "?"), reference.meta.get("technique", "?"),
                 int(mask.sum()), int(mask.size), (x, row),
                 (int(result.contrib_count[row, x]), int(reference.contrib_count[row, x])))
    if renderer is not None and technique is not None and reference_technique is not None:
        args = dict(render_args or {})
        got = renderer.render(technique, readback=False, debug_pixel=(x, row), **args).debug_lights
        args["opts"] = stochastic_draw(result) or None     # the reference's: the same draw
        want = renderer.render(reference_technique, readback=False, debug_pixel=(x, row),
                               **args).debug_lights
        m.missing = sorted(set(want.tolist()) - set(got.tolist()))
        m.extra = sorted(set(got.tolist()) - set(want.tolist()))
    if out_dir is not None:
        m.images = write_images(Path(out_dir), result, reference, mask, m.first)
    return m


def _check_capped(result, reference, cap, renderer, technique, reference_technique,
                  render_args, out_dir) -> Mismatch | IntendedLoss:
    policy, dropped = cap
    if caps.per_tile(policy) and renderer is not None and technique is not None:
        return _check_tile_capped(result, reference, policy, renderer, technique, render_args,
                                  out_dir)
    if renderer is not None and technique is not None and reference_technique is not None:
        args = dict(render_args or {})
        args.pop("opts", None)
        frame = result.build.frame
        args["lights"] = caps.without(frame.lights, result.build.capped_ids,
                                      frame.camera.view_from_world)
        intended = renderer.render(reference_technique, **args)
        m = _compare(result, intended, renderer, technique, reference_technique,
                     dict(render_args or {}, lights=args["lights"]), out_dir)
        m = m if m is not None else _layers_mismatch(result, intended)
        if m is not None:
            m.reference += f" without the {dropped} lights {policy} dropped"
            return m
    else:
        over = result.contrib_count > reference.contrib_count
        if over.any():
            row, x = (int(v) for v in np.argwhere(over)[0])
            return Mismatch(result.meta.get("technique", "?"), reference.meta.get("technique", "?"),
                            int(over.sum()), int(over.size), (x, row),
                            (int(result.contrib_count[row, x]), int(reference.contrib_count[row, x])))
    lost = reference.contrib_count.astype(np.int64) - result.contrib_count.astype(np.int64)
    return IntendedLoss(result.meta.get("technique", "?"), reference.meta.get("technique", "?"),
                        policy, int(differing(result, reference).sum()), int(lost.size),
                        dropped, int(lost.sum()))


def _check_tile_capped(result, reference, policy, renderer, technique, render_args,
                       out_dir) -> Mismatch | IntendedLoss:
    """check() of a per-tile capped frame (module docstring): against the CPU's expected
    figures (app.tile_caps), after those figures' full lists are checked against the
    reference."""
    from . import tile_caps
    exp = tile_caps.expected(renderer, result, dict(render_args or {}), stochastic_draw(result))
    floor = _figures_mismatch("perfect's per-pixel lists", reference.meta.get("technique", "?"),
                              exp.full_count, exp.full_hash, reference)
    if floor is not None:                   # the lists the expectation is built on are wrong
        return floor
    name = result.meta.get("technique", "?")
    m = _figures_mismatch(name, f"{reference.meta.get('technique', '?')} less the {exp.entries} "
                          f"tile entries {policy} drops (CPU)", result.contrib_count,
                          result.contrib_hash, None, exp.count, exp.hash)
    if m is not None:
        x, row = m.first
        h, w = exp.count.shape
        got = renderer.render(technique, readback=False, debug_pixel=(x, row),
                              **dict(render_args or {})).debug_lights
        want = exp.kept_ids(x, row, h, w)
        m.missing = sorted(set(want) - set(got.tolist()))
        m.extra = sorted(set(got.tolist()) - set(want))
        if out_dir is not None:
            m.images = write_images(Path(out_dir), result, reference,
                                    differing_figures(result.contrib_count, result.contrib_hash,
                                                      exp.count, exp.hash), m.first)
        return m
    lost = reference.contrib_count.astype(np.int64) - result.contrib_count.astype(np.int64)
    return IntendedLoss(name, reference.meta.get("technique", "?"), policy,
                        int(differing(result, reference).sum()), int(lost.size), exp.lights,
                        int(lost.sum()), entries=exp.entries, tiles=exp.tiles)


def _figures_mismatch(name, against, count, hashes, reference, want_count=None,
                      want_hash=None) -> Mismatch | None:
    """A Mismatch (no lights named yet) where (count, hashes) differ from the reference's
    figures (or want_count, want_hash), else None."""
    if reference is not None:
        want_count, want_hash = reference.contrib_count, reference.contrib_hash
    mask = differing_figures(count, hashes, want_count, want_hash)
    if not mask.any():
        return None
    row, x = (int(v) for v in np.argwhere(mask)[0])
    return Mismatch(name, against, int(mask.sum()), int(mask.size), (x, row),
                    (int(count[row, x]), int(want_count[row, x])))


def write_images(out: Path, result, reference, mask: np.ndarray, first) -> dict[str, Path]:
    """The technique's and the reference's tone-mapped images and a difference image (the
    reference in grey, differing pixels red, the first one yellow), scaled up to be seen."""
    from PIL import Image
    from .images import tonemap
    out.mkdir(parents=True, exist_ok=True)
    grey = tonemap(reference.image).mean(2, keepdims=True).repeat(3, 2) * 0.5
    diff = grey.astype(np.uint8)
    diff[mask] = MARK
    diff[first[1], first[0]] = FIRST
    scale = max(1, 512 // max(mask.shape))
    paths = {}
    for name, rgb in ((result.meta.get("technique", "technique"), tonemap(result.image)),
                      (reference.meta.get("technique", "reference"), tonemap(reference.image)),
                      ("difference", diff)):
        p = out / f"{name}.png"
        img = Image.fromarray(np.ascontiguousarray(rgb))
        img.resize((img.width * scale, img.height * scale), Image.NEAREST).save(p)
        paths[name] = p
    return paths
