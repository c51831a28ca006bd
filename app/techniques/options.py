"""Technique options, each declared once: its flag, type, range, help and the values a
benchmark study sweeps.  A technique's Options is a frozen dataclass composed of the groups
below (or its own fields); capture, the window, the benchmark and the report read the
declarations, so an option is written in one place only.

    @dataclass(frozen=True)
    class Options(GridOptions, ListOptions): ...

An option a technique does not declare is an error for that technique, never ignored; so is
an option its current mode does not read (Options.ignored(): e.g. raster's stencil in cluster
mode), set to other than its default.

A variant is a choice(): its names, written once, make its help ("0 fine per tile, 1 ..."),
its range, its study values and the name its stats give (Options.choice_name); its value is
the name's index, an int, so the dump's meta, results.csv and the variants' bit tests read
the number they always have.
"""
from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields, replace
from typing import ClassVar
import math

from cpu_prep import caps, limits, stochastic as stochmod, tree as treemod

from ..errors import UserError


# results.csv's study of an option's values run as the CPU stage alone: cpu_<option>
# (app.results; here so that techniques' notes read it without importing the results)
CPU_PREFIX = "cpu_"

_SPECS: dict = {}        # TechniqueOptions.specs() of each class (its fields never change)


@dataclass(frozen=True)
class OptionSpec:
    name: str                    # field name (dump meta, CSV column)
    kind: type                   # int | float | bool
    default: object
    help: str
    lo: float | None = None      # inclusive range (numbers)
    hi: float | None = None
    study: tuple = ()            # values a benchmark study sweeps (empty: not studied)
    power_of_two: bool = False
    study_scene: str | None = None   # the builtin scene the study is about (else the preset's)
    also_study: tuple = ()       # builtin scenes the study runs in as well, as study
                                 # "<option>@<scene>" (the technique's notes read them)
    choices: tuple[str, ...] = ()    # a choice(): value k is choices[k] (kind int, lo 0)

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")

    def label(self, value) -> str:
        """A choice's name for `value` (else the value as the command line writes it)."""
        return self.choices[int(value)] if self.choices else f"{value:g}"

    def check(self, value, where: str = "") -> object:
        """The value converted to the option's type, or a one-line UserError.  A choice also
        takes its name ("coarse per tile")."""
        pre = f"{where}: " if where else ""
        if self.choices:
            return self._check_choice(value, pre)
        if self.kind is bool:
            if not isinstance(value, (bool, int)) or value not in (0, 1):
                raise UserError(f"{pre}{self.flag} must be true or false (got {value!r})")
            return bool(value)
        try:
            v = self.kind(value)
        except (TypeError, ValueError):
            raise UserError(f"{pre}{self.flag} must be {self.kind.__name__} (got {value!r})") from None
        if isinstance(value, float) and self.kind is int and v != value:
            raise UserError(f"{pre}{self.flag} must be an integer (got {value!r})")
        if isinstance(v, float) and not math.isfinite(v):
            raise UserError(f"{pre}{self.flag} must be finite (got {value!r})")
        if (self.lo is not None and v < self.lo) or (self.hi is not None and v > self.hi):
            raise UserError(f"{pre}{self.flag} must be in {self.lo:g}..{self.hi:g} (got {v:g})")
        if self.power_of_two and (v < 1 or int(v) & (int(v) - 1)):
            raise UserError(f"{pre}{self.flag} must be a power of two (got {v})")
        return v

    def _check_choice(self, value, pre: str) -> int:
        """A choice's index from its name or its number ("2", 2), else a one-line UserError
        listing every value and name."""
        if isinstance(value, str) and value in self.choices:
            return self.choices.index(value)
        try:
            v = int(value)
        except (TypeError, ValueError):
            v = -1
        if isinstance(value, bool) or isinstance(value, float) and v != value \
                or not 0 <= v < len(self.choices):
            raise UserError(f"{pre}{self.flag} must be one of {choice_list(self.choices)} "
                            f"(got {value!r})")
        return v


def choice_list(names) -> str:
    """'0 fine per tile, 1 coarse per tile, ...': a choice's values and names."""
    return ", ".join(f"{k} {n}" for k, n in enumerate(names))


def _given(spec: OptionSpec, value) -> str:
    """The flag as given on the command line: --stencil / --no-stencil / --zbins 64."""
    if spec.kind is bool:
        return spec.flag if value else "--no-" + spec.flag[2:]
    return f"{spec.flag} {value:g}" if isinstance(value, float) else f"{spec.flag} {value}"


_declared = [0]     # declaration order: options list in the order they are written


def option(default, help: str, *, lo=None, hi=None, study=(), power_of_two=False, study_scene=None,
           also_study=()):
    """A dataclass field that declares a technique option.  `study_scene`: a builtin scene
    whose content the option is about (e.g. mixed light shapes), where the benchmark runs
    its study when the run has that scene (else in the preset's study scene).
    `also_study`: builtin scenes where the study runs a second time, as its own study
    "<option>@<scene>" (the slides' contention case beside the arena)."""
    return _option_field(default, help=help, lo=lo, hi=hi, study=tuple(study),
                         power_of_two=power_of_two, study_scene=study_scene,
                         also_study=tuple(also_study))


def _option_field(default, **spec):
    """The dataclass field of an option: its OptionSpec's fields but name, kind, default."""
    _declared[0] += 1
    return field(default=default, metadata={"option": spec, "order": _declared[0]})


def choice(default: str, names: tuple[str, ...], help: str, *, study: bool = False,
           study_scene=None, also_study=()):
    """A dataclass field that declares an option whose value is one of `names` (stored as
    its index): the help lists them after `help`, the range is theirs, a study (study=True)
    sweeps every one, and stats name a value by Options.choice_name.  `default`: a name."""
    names = tuple(names)
    if len(set(names)) != len(names) or default not in names:
        raise ValueError(f"choice names {names} repeat or lack the default {default!r}")
    return _option_field(names.index(default), help=f"{help}: {choice_list(names)}", lo=0,
                         hi=len(names) - 1, study=tuple(range(len(names))) if study else (),
                         study_scene=study_scene, also_study=tuple(also_study), choices=names)


@dataclass(frozen=True)
class TechniqueOptions:
    """Base of every technique's Options (no options of its own).  A technique whose modes
    read different options overrides ignored(); every instance is checked against it when
    made (make, with_, the constructor), so no option is silently ignored."""

    def __post_init__(self) -> None:
        self.check_modes()

    def ignored(self) -> dict[str, str]:
        """{option name: the mode that ignores it, in words} for these values: the options
        the technique does not read in the mode they select (e.g. raster with --cluster 1:
        {"stencil": "in cluster mode (--cluster 1)", ...}).  None by default."""
        return {}

    def check_modes(self) -> None:
        """A one-line UserError when an option this mode ignores is not at its default,
        naming the option and the mode."""
        ignored = self.ignored()
        for s in self.specs() if ignored else ():
            value = getattr(self, s.name)
            if s.name in ignored and value != s.default:
                raise UserError(f"{_given(s, value)} is ignored {ignored[s.name]}: leave it at "
                                f"its default ({_given(s, s.default)})")

    @classmethod
    def specs(cls) -> tuple[OptionSpec, ...]:
        # once a class: ~0.1 ms each, and every build asks (on_gpu, choice_name)
        got = _SPECS.get(cls)
        if got is not None:
            return got
        out = []
        for f in sorted(fields(cls), key=lambda f: f.metadata.get("order", 0)):
            meta = f.metadata.get("option")
            if meta is None:
                continue
            default = f.default if f.default is not MISSING else f.default_factory()
            out.append(OptionSpec(f.name, type(default), default, **meta))
        _SPECS[cls] = tuple(out)
        return _SPECS[cls]

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(s.name for s in cls.specs())

    @classmethod
    def make(cls, values: dict | None = None, where: str = "") -> "TechniqueOptions":
        """Options from {name: value}, each checked; a name this technique does not take
        is a one-line error naming the options it does take."""
        values = dict(values or {})
        specs = {s.name: s for s in cls.specs()}
        unknown = sorted(set(values) - set(specs))
        if unknown:
            flags = ", ".join("--" + n.replace("_", "-") for n in unknown)
            takes = ", ".join(s.flag for s in specs.values()) or "none"
            raise UserError(f"{where + ': ' if where else ''}{flags} "
                            f"{'is not an option' if len(unknown) == 1 else 'are not options'} "
                            f"of this technique (its options: {takes})")
        checked = {k: specs[k].check(v, where) for k, v in values.items()}
        try:
            return cls(**checked)
        except UserError as exc:                        # check_modes(): name the technique
            raise UserError(f"{where}: {exc}" if where else str(exc)) from None

    def with_(self, **values) -> "TechniqueOptions":
        return type(self).make(dict(self.as_dict(), **values))

    def as_dict(self) -> dict:
        return {s.name: getattr(self, s.name) for s in self.specs()}

    @classmethod
    def spec(cls, name: str) -> OptionSpec:
        return {s.name: s for s in cls.specs()}[name]

    def choice_name(self, name: str) -> str:
        """The name of a choice option's value ("coarse per tile"): what stats and notes say."""
        return self.spec(name).label(getattr(self, name))


# ---- option groups shared by several techniques (each option declared here once) ----

@dataclass(frozen=True)
class TileOptions(TechniqueOptions):
    tile: int = option(limits.DEFAULT_TILE, "screen tile size in pixels", lo=4, hi=256,
                       study=(16, 32, 48, 64))


@dataclass(frozen=True)
class SliceOptions(TileOptions):
    slices: int = option(limits.DEFAULT_SLICES, "depth slices of the 2.5D grid (listing 4)",
                         lo=2, hi=64)
    near_slice_depth: float = option(limits.DEFAULT_NEAR_SLICE_DEPTH,
                                     "far end of the near slice, view depth (Persson: 5 m)",
                                     lo=1e-3, hi=1e6)


@dataclass(frozen=True)
class ListOptions(TechniqueOptions):
    duplicated: bool = option(False, "lists hold copies of the light data instead of indices "
                                     "(tree paper figure 5)", study=(False, True))


@dataclass(frozen=True)
class TreeOptions(TechniqueOptions):
    lights_per_leaf: int = option(limits.DEFAULT_LIGHTS_PER_LEAF, "lights per tree leaf", lo=1, hi=4096)
    # the 15-bit skip count caps a tree at 16,384 leaves; larger caps are refused by the
    # build with that reason (cpu_prep.tree.leaves_per_cell)
    max_leaves: int = option(limits.DEFAULT_MAX_LEAVES, "leaf cap of one tree (a power of two)",
                             lo=1, hi=65536, power_of_two=True)
    sort_buckets: int = option(0, "0: exact depth sort; >0: the testbed's approximate bucket "
                                  "sort with this many buckets (512)", lo=0, hi=32768)
    # value k is cpu_prep.tree.BUILDS[k] (BUILD_BOTTOMUP, BUILD_TOPDOWN)
    tree_build: int = choice("bottomup", tuple(treemod.BUILDS.values()),
                             "tree build (bottomup: the paper's full trees, O(n); topdown: a "
                             "split per node minimising the expected work per pixel, O(n log n), "
                             "cpu_prep.tree_topdown)", study=True)


@dataclass(frozen=True)
class WaveOptions(TechniqueOptions):
    native_wave: bool = option(False, "native subgroup ops where the driver has them "
                                      "(else the emulated 64-lane wave)")


@dataclass(frozen=True)
class ScalarizeOptions(TechniqueOptions):
    scalarize: bool = option(False, "the wave walks its distinct cells (hybrid: its list cells) "
                                    "one at a time, each from a wave-uniform address (Drobot "
                                    "2017: hierarchical container scalarized over containers)",
                             study=(False, True))


@dataclass(frozen=True)
class CapOptions(TechniqueOptions):
    """`--cap-policy NAME` applies an engine's light cap to the view's visible lights before
    the technique builds its structure, dropping the over-cap lights in that engine's order:
    `hdrp-view` (HDRP, 512 punctual and 64 area lights a view, the first in scene order kept),
    `godot-512` (Godot Forward+, 512 of each light type, the first in scene order),
    `filament-256` (Filament, the 256 nearest to the camera), `urp-256`, `urp-32`, `urp-16`
    (URP's per-camera limit on desktop, mobile, low-end mobile: the nearest). The default,
    `none`, never drops a light. Each policy's source is written beside it in
    `cpu_prep/caps.py` (research: `docs/research/accuracy_policies.md`). A capped frame
    differs from `brute` on purpose: `--check` then renders `brute` without the dropped
    lights, and if the frame equals that at every pixel it prints `intended loss: N pixels,
    M lights dropped by POLICY` (exit 3: counted, neither a pass, 0, nor a failure); any
    other difference is a plain failure (exit 1).

    `hdrp-fptl-24` and `hdrp-fptl-63` are HDRP FPTL's per-tile caps (fptl's fine lists per
    tile only; elsewhere exit 2): each 16x16 tile keeps the lowest HDRP sort keys of each
    category, punctual and area, up to the budget (lightlistbuild.compute's clamp). A light
    dropped from some tiles is kept in others, so `--check` holds the frame to each pixel's
    exact list less the (tile, light) entries HDRP's keys drop (`app/tile_caps.py`), and the
    intended loss also counts the entries and tiles that dropped one."""

    # value k is cpu_prep.caps.NAMES[k]; each policy's budgets, drop order and source are
    # written there (docs/research/accuracy_policies.md)
    cap_policy: int = choice(caps.NONE, caps.NAMES,
                             "an engine's light cap on the view's visible lights, the over-cap "
                             "ones dropped in that engine's order (none: never drop; a capped "
                             "frame differs from brute on purpose, and --check counts the loss; "
                             "hdrp-fptl-*: per 16x16 tile, fptl only)")
    # a technique whose own list build applies the per-tile policies (caps.TILE_NAMES) says so
    tile_caps: ClassVar[bool] = False

    def check_modes(self) -> None:
        """A per-tile policy (hdrp-fptl-*) on a technique whose list build does not apply it
        (tile_caps False: all but fptl) is a one-line UserError naming the view's caps."""
        super().check_modes()
        policy = cap_policy(self)
        if caps.per_tile(policy) and not self.tile_caps:
            raise UserError(f"--cap-policy {policy} caps each 16x16 tile's fine-pruned list "
                            f"(HDRP FPTL): only fptl's list build takes it; this technique "
                            f"takes the view's caps ({', '.join(n for n in caps.NAMES if not caps.per_tile(n))})")


@dataclass(frozen=True)
class StochasticOptions(TechniqueOptions):
    """`--stochastic N` (every culling technique, brute included; a sampler draws its own) is
    Tokuyoshi & Harada's stochastic light culling ("Stochastic Light Culling", JCGT 2016) at
    budget t = 1/N of the brightest
    light's peak: each point, spot and capsule light draws its range by Russian roulette
    once a frame, r = sqrt(1/(alpha xi) - 1) with alpha = t I_max / I (at xi = 1 the cutoff
    study's radius at t, longer below), one xi per light shared by every pixel, hashed from
    (`--stochastic-seed`, `--stochastic-frame`, scene id) in `cpu_prep/stochastic.py`; every
    structure is built from those ranges, and a kept light adds its unbounded falloff
    divided by its evaluation probability, max(alpha, 1/(d^2+1)), so the frame is an
    unbiased estimate of the `UNBOUNDED_FALLOFF` reference (noise instead of the cut tails;
    tested: over K seeds the mean's error falls as 1/sqrt(K) as the closed-form variance
    predicts). Box lights have no distance falloff and stay exact. The same budget, seed and
    frame give brute the same ranges, so every technique stays exact against it (`--check`
    renders brute with the frame's draw); a seed reproduces its frame bit for bit. 0, the
    default, is off.

    A budget outside 0..65536 is one line and exit 2, and so are `--stochastic` with a view
    `--cap-policy` (not offered together yet) and `--stochastic-seed` or `--stochastic-frame`
    without `--stochastic` (there is no draw for them to choose). The bench's light cutoff
    study runs it (one draw) at t = 1/256 and 1/4096 with tiled and clustered, each row exact
    against brute of the same draw, beside the cutoff levels in the report's cutoff figure
    (dashed)."""

    # Tokuyoshi & Harada 2016 (cpu_prep/stochastic.py): the light's range drawn each frame,
    # its contribution weighted by 1/p; brute takes it too, so every technique stays exact
    # against brute under the same budget, seed and frame
    stochastic: int = option(0, "stochastic light culling (Tokuyoshi & Harada 2016) at budget "
                                "t = 1/N of the brightest light's peak (alpha_i = t I_max / I_i): "
                                "each light's range drawn by Russian roulette, a kept light "
                                "weighted by 1/p, unbiased against the unbounded falloff; box "
                                "lights stay exact; 0: off (exact window falloff)",
                             lo=0, hi=stochmod.MAX_BUDGET)
    stochastic_seed: int = option(0, "seed of the stochastic ranges' draw (with --stochastic)",
                                  lo=0, hi=2**31 - 1)
    stochastic_frame: int = option(0, "frame of the stochastic ranges' draw (with --stochastic: "
                                      "a new draw a frame, the same for a seed)", lo=0, hi=2**31 - 1)

    def ignored(self) -> dict[str, str]:
        """Without --stochastic there is no draw: its seed and frame select nothing."""
        out = dict(super().ignored())
        if not self.stochastic:
            out.update(dict.fromkeys(("stochastic_seed", "stochastic_frame"), "without --stochastic"))
        return out

    def check_modes(self) -> None:
        """--stochastic with a view cap policy is a one-line UserError: not offered together
        (the per-tile hdrp-fptl-* caps take it)."""
        super().check_modes()
        # A per-tile cap (HDRP FPTL) caps the lists built from the draw's ranges, and its check
        # renders the exact lists with the same draw on the same lights: sound.  A view cap's
        # check renders brute without the dropped lights, whose draw would then take its
        # brightest light (t I_max) from another set: not the same draw, so refused.
        if self.stochastic and cap_policy(self) != caps.NONE and not caps.per_tile(cap_policy(self)):
            raise UserError(f"--stochastic {self.stochastic} with --cap-policy "
                            f"{cap_policy(self)}: not offered together (a view cap's check "
                            f"renders brute without the dropped lights, which moves the "
                            f"stochastic budget's brightest light; the per-tile hdrp-fptl-* "
                            f"caps take it)")


@dataclass(frozen=True)
class FeatureVariantOptions(TechniqueOptions):
    # app/techniques/variants.py: HDRP's deferred feature variants, one program per tile mask
    feature_variants: bool = option(False, "per-tile feature variants (HDRP): each tile classified "
                                           "by the light shapes of its lists, specular or matte "
                                           "(hybrid: list / tree cells), then shaded by that "
                                           "mask's own program, dispatched indirectly over its "
                                           "tiles", study=(False, True),
                                    also_study=("corridor", "city"))


@dataclass(frozen=True)
class SampleOptions(TechniqueOptions):
    """The sampling techniques' budget and draw: `--light-samples S` light samples a shading pixel
    (each one light evaluation; RIS: S reservoirs), drawn from the pixel's random stream of
    (`--sample-seed`, `--sample-frame`, pixel): the same three give the same frame bit for bit,
    and over seeds the frames' mean converges to brute's (app.sampling_check)."""

    # no option study: the benchmark's sampling study sweeps S against culling (app.bench.sampling)
    light_samples: int = option(4, "light samples a shading pixel (each an unbiased estimate of "
                                   "the pixel's radiance over all lights, averaged)", lo=1, hi=64)
    sample_seed: int = option(0, "seed of the pixels' random streams", lo=0, hi=2**31 - 1)
    sample_frame: int = option(0, "frame of the pixels' random streams (a new draw a frame, the "
                                  "same for a seed)", lo=0, hi=2**31 - 1)


def sample_uniforms(opts) -> dict[str, object]:
    """The sampling passes' draw (glsl/sampling.glsl)."""
    return {"u_samples": opts.light_samples, "u_sample_seed": opts.sample_seed,
            "u_sample_frame": opts.sample_frame}


def stochastic(opts) -> tuple[int, int, int] | None:
    """(budget N, seed, frame) of options with stochastic culling on, else None."""
    if isinstance(opts, StochasticOptions) and opts.stochastic:
        return opts.stochastic, opts.stochastic_seed, opts.stochastic_frame
    return None


STOCHASTIC_NAMES = tuple(f.name for f in fields(StochasticOptions))


def cap_policy(opts) -> str:
    """The cap policy's name of a technique's options (caps.NONE when it takes none)."""
    return opts.choice_name("cap_policy") if isinstance(opts, CapOptions) else caps.NONE


def all_specs(option_classes) -> dict[str, OptionSpec]:
    """{name: spec} over several techniques' Options; one name, one declaration."""
    out: dict[str, OptionSpec] = {}
    for cls in option_classes:
        for s in cls.specs():
            if s.name in out and out[s.name] != s:
                raise ValueError(f"option '{s.name}' is declared twice, differently")
            out[s.name] = s
    return out


__all__ = ["option", "choice", "choice_list", "OptionSpec", "TechniqueOptions", "TileOptions", "SliceOptions",
           "ListOptions", "TreeOptions", "WaveOptions", "ScalarizeOptions", "CapOptions", "cap_policy",
           "StochasticOptions", "stochastic", "STOCHASTIC_NAMES", "FeatureVariantOptions",
           "SampleOptions", "sample_uniforms",
           "all_specs", "replace"]
