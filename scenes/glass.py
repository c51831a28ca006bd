"""Transparent geometry for the builtin scenes: glass panes and particles over a street
(the `city-glass` scene: `city` with these added; scenes/builtin.py).

The panes are thin boxes (a front and a back face: two transparent layers each): a shelter's
wall near the first camera, a glass screen across the street (most of the first view's
tiles, their edges crossed), canopies overhead and shop windows before the facades; the
particles are small boxes floating over the street in front of the screen.  The layout is fixed (its own
generator), so it does not depend on the light seed, and nothing here moves a light: the
scene's lights are city's, drawn before these meshes are added.
"""
from __future__ import annotations

import numpy as np

from .geometry import box_mesh
from .model import Mesh

GLASS_ALBEDO = (0.55, 0.75, 0.85)
GLASS_ROUGHNESS = 0.08            # glossy: GGX highlights of the street lights on the panes
GLASS_OPACITY = 0.3
PARTICLE_OPACITY = 0.5
PARTICLES = 48


def street_glass(half_street: float = 12.0) -> list[Mesh]:
    """Canopy panes, shop-window panes and particles over a street along -z, x in
    [-half_street, half_street], ground at y = 0."""
    out = []

    def add(lo, hi, albedo, opacity, roughness=0.0):
        m = box_mesh(lo, hi, albedo)
        m.roughness, m.opacity = roughness, opacity
        out.append(m)

    add((-6.0, 1.0, 11.9), (2.0, 7.0, 12.0),                # a shelter's wall facing the view
        GLASS_ALBEDO, GLASS_OPACITY, GLASS_ROUGHNESS)
    add((-half_street, 0.0, -30.1), (half_street, 10.0, -30.0),   # a glass screen across the street
        GLASS_ALBEDO, GLASS_OPACITY, GLASS_ROUGHNESS)
    for z in (-40.0, -70.0, -130.0):                         # canopies across the street
        add((-half_street + 0.5, 7.0, z - 8.0), (half_street - 0.5, 7.15, z),
            GLASS_ALBEDO, GLASS_OPACITY, GLASS_ROUGHNESS)
    for side in (-1.0, 1.0):                                 # shop windows before the facades
        x = side * (half_street - 0.6)
        for z in (8.0, -20.0, -60.0):
            xa, xb = sorted((x, x + side * 0.08))
            add((xa, 0.3, z - 14.0), (xb, 4.5, z), GLASS_ALBEDO, GLASS_OPACITY, GLASS_ROUGHNESS)
    g = np.random.default_rng(2718)                          # fixed layout
    for _ in range(PARTICLES):
        c = np.array([g.uniform(-8.0, 8.0), g.uniform(1.0, 9.0), g.uniform(-28.0, 20.0)])
        h = g.uniform(0.15, 0.45)
        add(c - h, c + h, tuple(g.uniform(0.6, 1.0, 3)), PARTICLE_OPACITY)
    return out
