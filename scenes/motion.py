"""Moving lights: a light's position is a pure function of (scene, frame, frames).

The one motion is the tree paper's first author's testbed's (kayru/LightCull,
`LightCullApp::animateLights`): every light travels in a straight line at its own
velocity and bounces off the faces of an animation box; nothing else of it changes
(radius, colour, direction, the shape's axes).  The testbed folds the travelled
distance back into the box per axis (a triangle wave of the normalised coordinate); so
does `bounce`, written so that frame 0 is the scene as loaded:

    u = (p0 - lo) / (hi - lo) + v t / (hi - lo)        per axis, in box units
    w = u mod 2;   p(t) = lo + (hi - lo) (w if w <= 1 else 2 - w)

Velocities are drawn from `np.random.default_rng(seed)`: a direction uniform on the
horizontal circle (the testbed's `animationSpeed (10, 0.01, 10)` moves its lights all
but horizontally), times `speed` m/s.  Frame k of a `frames`-long path loop is at
t = (k mod frames) / FPS seconds: the camera path's loop is the lights' loop too.

Vectorised: one numpy expression over every light (65,536+ lights a frame).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

KINDS = ("bounce",)
FPS = 30.0                 # frames a second of a path loop (frame k at k / FPS seconds)
MAX_SPEED = 1e4            # m/s: anything faster crosses every scene in a frame
# the builtin motion (--motion bounce): 4 m/s, a brisk walk: a 1 m light crosses its
# own radius in a few frames, so a path of a few frames moves lights across cells and caps
BUILTIN_SPEED = 4.0


@dataclass(frozen=True)
class Motion:
    """Lights bouncing in the box [lo, hi] at `speed` m/s, velocities drawn from `seed`."""
    kind: str
    speed: float
    seed: int
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]

    def to_dict(self) -> dict:
        """The scene file's form (docs/contracts.md "Contract: scene files", `motion`)."""
        return {"kind": self.kind, "speed": self.speed, "seed": self.seed,
                "bounds": {"min": list(self.lo), "max": list(self.hi)}}


def velocities(motion: Motion, n: int) -> np.ndarray:
    """(n, 3) float64 m/s: horizontal directions uniform on the circle, times the speed."""
    a = np.random.default_rng(int(motion.seed)).uniform(0.0, 2.0 * np.pi, n)
    v = np.zeros((n, 3))
    v[:, 0], v[:, 2] = np.cos(a), np.sin(a)
    return v * float(motion.speed)


def bounce(p0: np.ndarray, v: np.ndarray, lo, hi, t: float) -> np.ndarray:
    """Positions (n, 3) float64 at time t of points starting at p0 inside [lo, hi] with
    velocities v, reflected at the box's faces (an axis of zero extent stays put)."""
    lo = np.asarray(lo, np.float64)
    size = np.asarray(hi, np.float64) - lo
    flat = size <= 0
    safe = np.where(flat, 1.0, size)
    w = np.mod((np.asarray(p0, np.float64) - lo) / safe + v * (float(t) / safe), 2.0)
    p = lo + safe * np.where(w <= 1.0, w, 2.0 - w)
    return np.where(flat, p0, p)


def time_of(frame: int, frames: int) -> float:
    """Seconds of frame `frame` of a `frames`-long loop."""
    return (int(frame) % max(int(frames), 1)) / FPS


def lights_at(lights: np.ndarray, motion: Motion | None, frame: int, frames: int) -> np.ndarray:
    """The lights of frame `frame` (a new array; `lights` itself when nothing moves)."""
    if motion is None or len(lights) == 0 or motion.speed == 0:
        return lights
    out = lights.copy()
    p = bounce(lights["position"], velocities(motion, len(lights)), motion.lo, motion.hi,
               time_of(frame, frames))
    out["position"] = np.clip(p, motion.lo, motion.hi)      # float32 rounding stays inside
    return out


def outside(lights: np.ndarray, lo, hi) -> np.ndarray:
    """Ids of the lights whose position lies outside [lo, hi] (float32, as stored)."""
    p = lights["position"]
    bad = ((p < np.asarray(lo, np.float32)) | (p > np.asarray(hi, np.float32))).any(axis=1)
    return np.flatnonzero(bad)


def builtin_motion(scene, speed: float = BUILTIN_SPEED, seed: int = 0) -> Motion:
    """`--motion bounce` on any scene: the box of its geometry and its lights (a light drawn
    on a wall's outer face sits a little outside the geometry's box)."""
    lo, hi = scene.bounds()
    if len(scene.lights):
        p = scene.lights["position"].astype(np.float64)
        lo, hi = np.minimum(lo, p.min(0)), np.maximum(hi, p.max(0))
    return Motion("bounce", float(speed), int(seed), tuple(map(float, lo)), tuple(map(float, hi)))


MOTION_CHOICES = ("off", "bounce")


def with_motion(scene, name: str | None):
    """The scene with `--motion NAME` applied: None keeps the scene's own (a file's
    `motion`; a builtin has none), "off" stops it, "bounce" the builtin bounce."""
    if name is None:
        return scene
    if name not in MOTION_CHOICES:
        from .errors import SceneError
        raise SceneError(f"motion: must be one of {', '.join(MOTION_CHOICES)} (got {name!r})")
    scene.motion = None if name == "off" else builtin_motion(scene)
    return scene


__all__ = ["Motion", "KINDS", "FPS", "MOTION_CHOICES", "bounce", "velocities", "lights_at",
           "builtin_motion", "with_motion", "outside", "time_of"]
