"""The views the window shows, which of them a technique has, and the techniques that have
one: the window draws them (app.window, whose views.py holds the overlays), capture refuses
a view a technique lacks (--classify) without importing the window.  No GL.

    shaded   the displayed image: tonemap(exposure * radiance + ambient * albedo), as capture's --out
    heat     lights evaluated (or exact lights) per pixel, app.images' one heat-map definition;
             overlay mode: over the shaded image
    tiles    the technique's screen tiles (its Build's grid)
    slices   the technique's depth slices (grid.slices > 1, listing 4)
    classes  traversal case of each 8x8 wave (list / tree / mixed / empty)
    diff     pixels whose set of lights (contrib_count, contrib_hash) differs from the
             reference's (brute), red; it should be empty
    split    the current technique left, a second one right (shaded or heat)
    maps     the technique's own structure (Technique.maps: fptl's coarse and pruned lists
             per tile, zbin's bit arrays and z-bin ranges, raster's marked tiles), M: next
    variants each tile's feature variant (--feature-variants), colour-coded, the legend in
             the panel; drawn by its own pass over the shaded image (app.window.variant_view)

A technique offers the views in its `views` attribute (app.techniques.base.Technique.views:
shaded, heat, diff, split for every one; tiles, slices, classes where it has that structure):
a view it does not have is not offered for it.
"""
from __future__ import annotations

VIEWS = ("shaded", "heat", "tiles", "slices", "classes", "diff", "split", "maps")
# views drawn by a pass of their own over the shaded view (present.frag knows VIEWS only)
PASS_VIEWS = ("variants",)
ALL_VIEWS = VIEWS + PASS_VIEWS
SPLIT_VIEWS = ("shaded", "heat")
HEAT_OF = ("evaluated", "exact")


def views_of(technique) -> tuple[str, ...]:
    """The views a technique offers, in the window's order."""
    own = set(getattr(technique, "views", ()) or ("shaded",))
    unknown = own - set(ALL_VIEWS)
    if unknown:
        raise ValueError(f"technique {technique.name}: unknown view(s) {sorted(unknown)} "
                         f"(known: {', '.join(ALL_VIEWS)})")
    return tuple(v for v in ALL_VIEWS if v in own)


def with_view(registry, view: str) -> list[str]:
    """Names of the techniques that offer `view`."""
    return [t.name for t in registry.values() if view in views_of(t)]
