"""What a replay or a culling pass's count yields: Figures, per loop kind and field, and the
analytic figures of a pass whose loops have fixed trip counts."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from scenes.model import LIGHT_TYPES

from .kinds import FIELDS, ISSUED, KINDS, LANES, LINE, NTYPES
from .program import FrameData


@dataclass
class Figures:
    """One pass at one wave width: per loop kind (KINDS x FIELDS), the light shapes tested
    and shaded, and the frame's totals."""
    width: int
    waves: int                     # launched (every group's 64 / W waves)
    busy_waves: int                # with at least one shading lane
    pixels: int
    shading_pixels: int
    loops: np.ndarray = field(default_factory=lambda: np.zeros((len(KINDS), len(FIELDS)), np.int64))
    tested: np.ndarray = field(default_factory=lambda: np.zeros(NTYPES, np.int64))
    shaded: np.ndarray = field(default_factory=lambda: np.zeros(NTYPES, np.int64))
    specular: int = 0              # light iterations in which an affected lane ran GGX
    unique_bytes: dict = field(default_factory=dict)   # buffer -> bytes of distinct lines read
    barriers: int = 0              # per pass (every group's)
    atomics: int = 0               # global atomics (culling passes)
    shared_atomics: int = 0
    graphics: bool = False         # a raster pass (vertex and fragment work)
    fragments: int = 0             # its fragments (depth tests)
    # what one issued iteration of each kind costs, counted from the pass's own program
    # (app.model.counts.program_counts: kind / "test:<shape>" / "shade:<shape>" / "ggx" /
    # "wave" -> [alu, trans, idiv, wred]); None until the cost model's counts are attached
    ops: dict | None = None
    programs: tuple = ()           # the shader files of the programs the counts come from
    stands_for: str = ""           # a regex of the frame's passes this figure prices, where
                                   # it is not one pass of its own name (raster's proxies)

    def loop_sum(self, name: str) -> int:
        """A field summed over every loop kind."""
        return int(self.loops[:, FIELDS.index(name)].sum())

    def loop(self, kind: str) -> dict[str, int]:
        return dict(zip(FIELDS, (int(v) for v in self.loops[KINDS.index(kind)])))

    def as_dict(self) -> dict:
        """Flat figures (the benchmark's stats column and the report): everything the cost
        model reads, so that a row's modelled times can be derived again (from_dict)."""
        out = {"width": self.width, "waves": self.waves, "busy_waves": self.busy_waves,
               "barriers": self.barriers, "pixels": self.pixels,
               "shading_pixels": self.shading_pixels, "graphics": bool(self.graphics)}
        for k, kind in enumerate(KINDS):
            for f, name in enumerate(FIELDS):
                if self.loops[k, f]:
                    out[f"{kind}_{name}"] = int(self.loops[k, f])
        for t, name in enumerate(LIGHT_TYPES):
            if self.tested[t]:
                out[f"tested_{name}"] = int(self.tested[t])
                out[f"shaded_{name}"] = int(self.shaded[t])
        out["specular_iterations"] = int(self.specular)
        out["unique_bytes"] = int(sum(self.unique_bytes.values()))
        for k in ("atomics", "shared_atomics", "fragments"):
            if getattr(self, k):
                out[k] = int(getattr(self, k))
        if self.ops is not None:
            out["ops"] = {k: [float(x) for x in v] for k, v in sorted(self.ops.items())}
            out["programs"] = list(self.programs)
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "Figures":
        """The figures as_dict() wrote (unique bytes as one total: the model sums them)."""
        f = cls(width=int(d["width"]), waves=int(d["waves"]), busy_waves=int(d["busy_waves"]),
                pixels=int(d["pixels"]), shading_pixels=int(d["shading_pixels"]),
                specular=int(d.get("specular_iterations", 0)),
                unique_bytes={"all": int(d.get("unique_bytes", 0))},
                barriers=int(d.get("barriers", 0)), atomics=int(d.get("atomics", 0)),
                shared_atomics=int(d.get("shared_atomics", 0)), graphics=bool(d["graphics"]),
                fragments=int(d.get("fragments", 0)), ops=d.get("ops"),
                programs=tuple(d.get("programs", ())))
        for k, kind in enumerate(KINDS):
            for j, name in enumerate(FIELDS):
                f.loops[k, j] = int(d.get(f"{kind}_{name}", 0))
        for t, name in enumerate(LIGHT_TYPES):
            f.tested[t] = int(d.get(f"tested_{name}", 0))
            f.shaded[t] = int(d.get(f"shaded_{name}", 0))
        return f

    def scaled(self, factor: float, caps: dict) -> "Figures":
        """These figures of a sample of the waves stood for the whole pass: the work scaled
        by `factor`, each buffer's distinct bytes too but never past its size (`caps`)."""
        k = lambda v: int(round(v * factor))
        out = Figures(width=self.width, waves=self.waves, busy_waves=k(self.busy_waves),
                      pixels=self.pixels, shading_pixels=k(self.shading_pixels),
                      loops=np.rint(self.loops * factor).astype(np.int64),
                      tested=np.rint(self.tested * factor).astype(np.int64),
                      shaded=np.rint(self.shaded * factor).astype(np.int64),
                      specular=k(self.specular), barriers=k(self.barriers),
                      unique_bytes={n: min(k(b), -(-caps.get(n, b) // LINE) * LINE)
                                    for n, b in self.unique_bytes.items()},
                      atomics=self.atomics, shared_atomics=self.shared_atomics,
                      graphics=self.graphics, fragments=self.fragments, ops=self.ops,
                      programs=self.programs)
        return out

    @property
    def simd_use(self) -> float:
        """Active lanes per issued lane slot over every loop kind (1.0: no lane idle)."""
        issued = self.loops[:, ISSUED].sum()
        return float(self.loops[:, LANES].sum() / (issued * self.width)) if issued else 1.0


def per_tile(frame: FrameData, tile: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    """(pixels, covered pixels) per screen tile of `tile` px (row-major) and the tile grid."""
    x, y = frame.pixel_xy
    tx, ty = -(-frame.size[0] // tile), -(-frame.size[1] // tile)
    t = (y // tile) * tx + x // tile
    return (np.bincount(t, minlength=tx * ty), np.bincount(t[frame.shading], minlength=tx * ty),
            tx, ty)


def analytic(width: int, waves: int, loops: dict, unique_bytes: dict | None = None, **kw) -> Figures:
    """Figures of a pass whose loops have fixed trip counts (a culling pass): per kind
    (issued, lanes, vector loads, vector lines[, scalar loads, scalar lines]) summed over its
    waves, counted by the technique from the frame's sizes and counts."""
    f = Figures(width=width, waves=int(waves), busy_waves=int(waves), pixels=0, shading_pixels=0,
                unique_bytes=dict(unique_bytes or {}), **kw)
    cols = ("issued", "lanes", "vector_loads", "vector_lines", "scalar_loads", "scalar_lines")
    for kind, vals in loops.items():
        for name, v in zip(cols, vals):
            f.loops[KINDS.index(kind), FIELDS.index(name)] += int(v)
    return f
