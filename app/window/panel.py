"""The live panel's model: what can be changed and how, with no GL and no imgui.

    LabState   what the next frame renders and shows: technique, its options, view, light
               count / seed / distribution, exposure, ambient, heat scale, split, inspect
    Panel      the controls of the current state, read from the declarations (a technique's
               options: its Options.specs(), flag / range / help), and `apply`, the one way
               a value gets in: the imgui widgets (app.window.ui) call it when a widget
               changes, scripted runs (--keys "tile=32") and tests call it the same way.
               Changes apply on the next frame (the frame being drawn already rendered).

Every value is checked where it is applied; a bad one is a UserError (one line), which the
window shows as a message and the state keeps its value.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
import math
from typing import Callable

from .. import images
from ..errors import UserError
from ..display import DISPLAY, DISPLAY_FLAGS
from ..given_options import GivenOptions, flag
from ..views import HEAT_OF, SPLIT_VIEWS, views_of
from .views import STEREO_VIEWS

DISTRIBUTIONS = ("uniform", "geometry")
# the exposure slider is in EV: log2 of the exposure factor's declared range
EV_RANGE = tuple(math.log2(v) for v in (DISPLAY["exposure"].lo, DISPLAY["exposure"].hi))


@dataclass
class LabState:
    registry: dict                          # name -> technique (app.techniques.REGISTRY)
    technique: str
    options: GivenOptions
    lights: int
    view: str = "shaded"
    seed: int = 0
    distribution: str | None = None         # None: the scene's own
    builtin: bool = True                    # a builtin scene: lights are drawn (count, seed, distribution)
    file_lights: int = 0                    # a scene file: the lights it has
    max_lights: int = 4_194_304
    exposure_auto: bool = True
    exposure_ev: float = 0.0                # manual exposure = 2 ** ev
    exposure_now: float = 1.0               # the last frame's exposure (auto or manual)
    ambient: float = images.AMBIENT
    heat_max: float = 0.0                   # 0: the frame's largest count
    heat_of: str = "evaluated"
    heat_overlay: bool = False
    split_with: str = ""
    split_view: str = "shaded"
    split_at: float = 0.0                   # 0: the middle of what the panel leaves visible
    inspect: bool = False
    target_fps: float = DISPLAY["target_fps"].default   # dynamic resolution (app.window.scale)
    move_scale: float | None = None         # a fixed scale of moving frames; None: the target's
    hud: bool = True
    panel: bool = True
    version: int = 0                        # bumped by every change
    messages: list = field(default_factory=list)
    scene_views: tuple = ()                 # the scene's views (app.window.views.WINDOW_VIEWS): froxels in fog
    stereo: bool = False                    # --views stereo / B: both eyes side by side (stereo_view.py)
    # why a technique with its options cannot render this scene (fog, stereo's way): a line, or None
    refusal: Callable | None = None

    @property
    def tech(self):
        return self.registry[self.technique]

    def views(self) -> tuple[str, ...]:
        own = views_of(self.tech) + self.scene_views
        return tuple(v for v in own if v in STEREO_VIEWS) if self.stereo else own

    def changed(self, message: str | None = None) -> None:
        self.version += 1
        if message:
            self.messages.append(message)

    # ---- the state's own rules ---------------------------------------------------------------
    def set_technique(self, name: str) -> None:
        if name not in self.registry:
            raise UserError(f"unknown technique '{name}' (choose from {', '.join(self.registry)})")
        why = self.refused(name)
        if why:
            raise UserError(why)
        self.technique = name
        self.options.for_technique(self.tech)          # its options exist and are valid
        note = None
        if self.view not in self.views():
            note = f"{name} has no {self.view} view: shaded"
            self.view = "shaded"
        if self.split_with == name:
            self.split_with = self.default_split()
        self.changed(note)

    def refused(self, name: str) -> str | None:
        """Why technique `name` with its options cannot render here (self.refusal), or None."""
        if self.refusal is None:
            return None
        t = self.registry[name]
        return self.refusal(t, self.options.for_technique(t)[0])

    def set_view(self, view: str) -> None:
        if view not in self.views():
            raise UserError(f"{self.technique} has no {view} view (its views: {', '.join(self.views())})")
        self.view = view
        self.changed()

    def next_view(self) -> None:
        vs = self.views()
        self.view = vs[(vs.index(self.view) + 1) % len(vs)] if self.view in vs else vs[0]
        self.changed()

    def choose_number(self, k: int) -> None:
        """The k-th technique in registry order (keys 1-9)."""
        names = list(self.registry)
        if not 1 <= k <= len(names):
            raise UserError(f"no technique {k}: {len(names)} registered (T: the next one; the panel lists all)")
        self.set_technique(names[k - 1])

    def next_technique(self) -> None:
        """The next technique in registry order, every one (past the ninth too), then the first."""
        names = list(self.registry)
        at = names.index(self.technique)
        later = names[at + 1:] + names[:at + 1]
        # past the ones that cannot render here (a fog scene's, stereo's way)
        self.set_technique(next((n for n in later if self.refused(n) is None), later[0]))

    def double_lights(self) -> None:
        self.set_lights(min(max(1, self.lights * 2), self.max_lights if self.builtin else self.file_lights))

    def halve_lights(self) -> None:
        self.set_lights(self.lights // 2)

    def default_split(self) -> str:
        """The technique the split view compares with: the first other one that is neither
        the reference nor the floor, else any other."""
        others = [n for n in self.registry if n != self.technique]
        plain = [n for n in others if self.registry[n].role == "technique"]
        return (plain or others or [self.technique])[0]

    def set_lights(self, n) -> None:
        n = _int(n, "lights")
        top = self.max_lights if self.builtin else self.file_lights
        if not 0 <= n <= top:
            what = "the scene file has" if not self.builtin else "at most"
            raise UserError(f"lights must be in 0..{top} ({what} {top})")
        self.lights = n
        self.changed()

    @property
    def exposure_manual(self) -> float:
        return 2.0 ** self.exposure_ev


@dataclass
class Control:
    key: str                    # what `apply` and --keys "key=value" name
    label: str
    kind: str                   # int, float, bool, choice, button, text
    value: object = None
    lo: float | None = None
    hi: float | None = None
    choices: tuple = ()
    help: str = ""
    section: str = ""
    log: bool = False           # a slider on a log scale (light counts, ranges over decades)
    power_of_two: bool = False
    set: Callable | None = None


@lru_cache(maxsize=None)
def accepted(options_cls, name: str) -> tuple[str, ...]:
    """The values of choice option `name` that a technique's Options take with its other
    options at their defaults: its own check decides (check_modes; e.g. only fptl's list
    build takes the per-tile cap policies), so no second list says which."""
    spec = options_cls.spec(name)
    out = []
    for k, value in enumerate(spec.choices):
        try:
            options_cls(**{name: k})
        except UserError:
            continue
        out.append(value)
    return tuple(out)


def spec_control(spec, label: str, value, section: str, set, help: str | None = None,
                 options_cls=None) -> Control:
    """The control of a declared option (app.techniques.options.OptionSpec): its kind,
    range and help as declared; a slider on a log scale where the range spans decades; a
    choice()'s names in a combo (its setter takes the name, as the command line does): of a
    technique's option (`options_cls`), the ones it takes (accepted()) and the current one."""
    if spec.choices:
        current = spec.label(value)
        choices = spec.choices if options_cls is None else tuple(
            c for c in spec.choices if c in accepted(options_cls, spec.name) or c == current)
        return Control(spec.name, label, "choice", current, choices=choices,
                       lo=spec.lo, hi=spec.hi, section=section, set=set,
                       help=help if help is not None else f"{flag(spec.name)}: {spec.help}")
    kind = {bool: "bool", int: "int", float: "float"}[spec.kind]
    lo, hi = spec.lo, spec.hi
    return Control(spec.name, label, kind, value, lo=lo, hi=hi, section=section, set=set,
                   help=help if help is not None else f"{flag(spec.name)}: {spec.help}",
                   power_of_two=spec.power_of_two,
                   log=kind != "bool" and lo is not None and hi is not None and lo > 0 and hi / lo >= 1e3)


def _int(v, what: str) -> int:
    if isinstance(v, str):
        try:
            v = int(v.strip())
        except ValueError:
            raise UserError(f"{what} must be an integer (got '{v}')") from None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v):
        raise UserError(f"{what} must be an integer (got {v!r})")
    return int(v)


def _float(v, what: str, lo: float, hi: float) -> float:
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise UserError(f"{what} must be a number (got {v!r})") from None
    if not (math.isfinite(v) and lo <= v <= hi):
        raise UserError(f"{what} must be in {lo:g}..{hi:g} (got {v:g})")
    return v


def _bool(v, what: str) -> bool:
    if isinstance(v, str):
        t = v.strip().lower()
        if t in ("1", "true", "on", "yes"):
            return True
        if t in ("0", "false", "off", "no"):
            return False
        raise UserError(f"{what} must be on or off (got '{v}')")
    if isinstance(v, (bool, int)) and v in (0, 1):
        return bool(v)
    raise UserError(f"{what} must be on or off (got {v!r})")


def _choice(v, what: str, choices) -> str:
    if v not in choices:
        raise UserError(f"{what} must be one of {', '.join(map(str, choices))} (got {v!r})")
    return v


class Panel:
    """The controls of a LabState, and the one way values get in (`apply`).  `actions`
    are the window's buttons: {key: (label, callback)} (play, record, screenshot ...)."""

    FIXED_KEYS = ("technique", "view", "defaults", "lights", "seed", "distribution",
                  "exposure_auto", "exposure_ev", "ambient", "heat_max", "heat_of",
                  "heat_overlay", "split_with", "split_view", "split_at", "inspect", "target_fps")

    def __init__(self, state: LabState, actions: dict | None = None):
        self.state = state
        self.actions = dict(actions or {})

    # ---- the controls -------------------------------------------------------------------------
    def controls(self) -> list[Control]:
        s = self.state
        tech = s.tech
        out = [Control("technique", "technique", "choice", s.technique, choices=tuple(s.registry),
                       help="; ".join(f"{t.name}: {t.summary}" for t in s.registry.values()),
                       section="technique", set=s.set_technique),
               Control("view", "view", "choice", s.view, choices=s.views(),
                       help="the views this technique has", section="technique", set=s.set_view)]
        opts, _ = s.options.for_technique(tech)
        for spec in tech.Options.specs():
            out.append(spec_control(spec, spec.name.replace("_", " "), getattr(opts, spec.name), "options",
                                    lambda v, n=spec.name: self._set_option(n, v), options_cls=tech.Options))
        out.append(Control("defaults", "defaults", "button", help="this technique's declared defaults "
                           "(and the command line's flags)", section="options", set=self._defaults))
        if s.builtin:
            out += [Control("lights", "lights", "int", s.lights, lo=0, hi=s.max_lights, log=True,
                            help="light count (drawn anew with the seed and distribution)",
                            section="lights", set=s.set_lights),
                    Control("seed", "seed", "int", s.seed, lo=0, hi=2**31 - 1, help="light draw seed",
                            section="lights", set=self._set_seed),
                    Control("distribution", "distribution", "choice", s.distribution or "scene default",
                            choices=("scene default",) + DISTRIBUTIONS, section="lights",
                            help="lights uniform in the scene's box or on its geometry",
                            set=self._set_distribution)]
        else:
            out.append(Control("lights", "lights", "int", s.lights, lo=0, hi=s.file_lights,
                               help="the first N lights of the scene file", section="lights",
                               set=s.set_lights))
        out += [Control("exposure_auto", "auto exposure", "bool", s.exposure_auto, section="display",
                        help=f"the {images.EXPOSURE_PERCENTILE:.0%} luminance of the lit pixels "
                             f"maps to {images.EXPOSURE_TARGET:g} (app.images)",
                        set=lambda v: self._setattr("exposure_auto", _bool(v, "auto exposure"))),
                Control("exposure_ev", "exposure EV", "float",
                        math.log2(s.exposure_now) if s.exposure_auto and s.exposure_now > 0 else s.exposure_ev,
                        lo=EV_RANGE[0], hi=EV_RANGE[1], section="display", set=self._set_ev,
                        help=f"--exposure 2^EV: {DISPLAY['exposure'].help}; moving it turns auto "
                             f"exposure off"),
                self._display("ambient", "ambient"),
                self._display("heat_max", "heat max"),
                spec_control(DISPLAY["target_fps"], "target fps", s.target_fps, "display",
                             self._set_target_fps,
                             help=f"--target-fps: {DISPLAY['target_fps'].help}; moving it ends a "
                                  f"fixed --move-scale"),
                Control("heat_of", "heat of", "choice", s.heat_of, choices=HEAT_OF, section="display",
                        help="lights evaluated per pixel, or exact lights (contrib_count)",
                        set=lambda v: self._setattr("heat_of", _choice(v, "heat of", HEAT_OF))),
                Control("heat_overlay", "heat over shaded", "bool", s.heat_overlay, section="display",
                        help="the heat map over the shaded image",
                        set=lambda v: self._setattr("heat_overlay", _bool(v, "heat over shaded"))),
                Control("split_with", "split with", "choice", s.split_with,
                        choices=tuple(n for n in s.registry if n != s.technique), section="compare",
                        help="the technique on the right half of the split view",
                        set=self._set_split),
                Control("split_view", "split shows", "choice", s.split_view, choices=SPLIT_VIEWS,
                        section="compare", help="both halves as shaded images or heat maps",
                        set=lambda v: self._setattr("split_view", _choice(v, "split shows", SPLIT_VIEWS))),
                self._display("split_at", "split at", "compare"),
                Control("inspect", "inspect cursor", "bool", s.inspect, section="inspect",
                        help="the light and the tile under the cursor, with its light list",
                        set=lambda v: self._setattr("inspect", _bool(v, "inspect")))]
        for key, (label, callback) in self.actions.items():
            out.append(Control(key, label, "button", section="camera", set=lambda v, c=callback: c()))
        return out

    def _display(self, name: str, label: str, section: str = "display") -> Control:
        """A display option's control (options.DISPLAY: the command line's declaration)."""
        spec = DISPLAY[name]
        return spec_control(spec, label, getattr(self.state, name), section,
                            lambda v: self._setattr(name, spec.check(v)),
                            help=None if name in DISPLAY_FLAGS else spec.help)

    def control(self, key: str) -> Control:
        for c in self.controls():
            if c.key == key:
                return c
        known = ", ".join(c.key for c in self.controls())
        raise UserError(f"no control '{key}' for {self.state.technique} (controls: {known})")

    # ---- the one way in -----------------------------------------------------------------------
    def apply(self, key: str, value=None) -> None:
        """Set control `key` to `value` (a string is converted by the control's kind) as a
        widget does; raises UserError with one line when the value is refused."""
        c = self.control(key)
        if c.kind == "int" and isinstance(value, str):
            value = _int(value, c.label)
        elif c.kind == "float" and isinstance(value, str):
            value = _float(value, c.label, -math.inf, math.inf)
        elif c.kind == "bool":
            value = _bool(value, c.label)
        c.set(value)

    # ---- setters -------------------------------------------------------------------------------
    def _setattr(self, name: str, value) -> None:
        setattr(self.state, name, value)
        self.state.changed()

    def _set_option(self, name: str, value) -> None:
        s = self.state
        before = s.options.for_technique(s.tech)[0].as_dict().get(name)
        s.options.set(s.tech, name, value)
        why = s.refused(s.technique)
        if why:                                  # not for this scene: the value it had
            s.options.set(s.tech, name, before)
            raise UserError(why)
        s.changed()

    def _defaults(self, _=None) -> None:
        self.state.options.reset(self.state.tech)
        self.state.changed(f"{self.state.technique}: options back to their defaults")

    def _set_seed(self, v) -> None:
        v = _int(v, "seed")
        if not 0 <= v <= 2**31 - 1:
            raise UserError(f"seed must be in 0..{2**31 - 1} (got {v})")
        self._setattr("seed", v)

    def _set_distribution(self, v) -> None:
        v = _choice(v, "distribution", ("scene default",) + DISTRIBUTIONS)
        self._setattr("distribution", None if v == "scene default" else v)

    def _set_ev(self, v) -> None:
        v = _float(v, "exposure EV", *EV_RANGE)
        self.state.exposure_ev = v
        self.state.exposure_auto = False
        self.state.changed()

    def _set_target_fps(self, v) -> None:
        self.state.target_fps = DISPLAY["target_fps"].check(v)
        self.state.move_scale = None
        self.state.changed()

    def _set_split(self, v) -> None:
        s = self.state
        _choice(v, "split with", tuple(n for n in s.registry if n != s.technique))
        self._setattr("split_with", v)


def panel_keys(registry) -> set[str]:
    """Every key a scripted run may set (--keys "key=value"): the fixed controls and every
    option of every technique (whether the current one has it is checked when applied)."""
    keys = set(Panel.FIXED_KEYS)
    for t in registry.values():
        keys.update(t.Options.names())
    return keys
