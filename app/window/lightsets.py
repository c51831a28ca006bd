"""The lights the window renders: a builtin scene's are drawn anew for each count, seed and
distribution the panel chooses (a few draws kept, so +/- back and forth is quick); a scene
file's are its first N.  No GL."""
from __future__ import annotations

import numpy as np

from . import progress

KEPT = 8


class LightSets:
    def __init__(self, scene, scene_arg: str, state):
        """state: the panel's state at the start, whose draw `scene` was loaded with."""
        self.scene = scene
        self.scene_arg = scene_arg               # what --scene named: load_scene draws from it
        self.sets: dict = {self.key(state): scene.lights}

    @staticmethod
    def key(state) -> tuple:
        return (state.lights, state.seed, state.distribution) if state.builtin else (state.lights,)

    def of(self, state) -> np.ndarray:
        if not state.builtin:
            return self.scene.lights[:state.lights]
        key = self.key(state)
        if key not in self.sets:
            from scenes import load_scene
            with progress.step(f"drawing {state.lights:,} lights"):
                self.sets[key] = load_scene(self.scene_arg, lights=state.lights, seed=state.seed,
                                            distribution=state.distribution).lights
            if len(self.sets) > KEPT:
                self.sets.pop(next(iter(self.sets)))
        return self.sets[key]
