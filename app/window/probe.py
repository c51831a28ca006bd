"""How long a technique's frame takes, before the window commits to it.

    fastest()   the start-up probe: every candidate technique (not the reference, not the
                floor: both are there to compare against, not to fly with) timed at the
                window's size (at most PROBE_PIXELS of it) with the scene's first camera, the
                likely fastest first; the fastest frame there (wall clock: what the window
                waits for) wins.  Two steps:
                  ranking: two frames each at RANK_SCALE of the probe's size (1/64 of its
                  pixels), the first compiling the technique's shaders and kernels (which
                  the window would pay anyway, on its first frame of it: seconds each from
                  a cold numba cache; not in the budget), the second ranking it; a first
                  frame whose GPU passes took over LONG_FRAME_MS is its own rank (its
                  compile a small share of it).  Each ranking frame has a deadline
                  (Renderer.render's: between two passes, each dispatch window its own; the
                  CPU build and compiles not counted) of the whole budget: a frame at the
                  probe size does at least the work of one at 1/64 of its pixels (the same
                  lights culled, 64x the pixels shaded), so a candidate whose ranking frame
                  alone runs past the budget would be expected over it, which the timing
                  step below does not start; it is left out for time (its console line;
                  "not probed for time") after a few seconds instead of a frame of minutes
                  (a million lights on llvmpipe: tiled's, 227 s).  A single dispatch or draw
                  runs whole, so a frame can overrun the deadline by its longest pass.  When
                  every ranking frame overruns, they are timed in the given order (the
                  first whole: the window needs a start).  The
                  ranking has its console line.
                  timing: one frame each at the probe size, in the ranking's order (a second
                  one when that frame built new GL programs: a variant only this size needs),
                  while the probe is within PROBE_BUDGET_S (6 s; LAB_PROBE_BUDGET_S sets
                  it) from the start of this step, the first always; a candidate whose
                  expected frame (the last timed one's, scaled by their ranking frames) is
                  over the whole budget is not started either, and a frame after the first
                  stops (the same deadline) once it alone runs past the budget; the first
                  has none (the start needs one measure).  What the budget leaves out is
                  then the ranking's slow end (a million lights: tiled, whose per-tile cull
                  loops over every visible light, 395 s a frame on llvmpipe), not whatever
                  the registry lists first.
                Why not rank and choose at the small size: a culling structure's tiles and
                cells cover more of the view at a lower resolution, so its lists grow and the
                ranking can change between close techniques (tiled: 2x slower per pixel at
                half size on the city); the small frame only orders, the choice is measured
                at the probe size.  A candidate that would refuse the frame
                (Technique.refusal: a limit it meets at the probe's size or the window's,
                from the counts and options) is left out before it is built, one that
                refuses in its build after it; the start's lines name each with its limit.
                One that refuses only at the small size is timed after the ranked ones (two
                frames: its first compiles).  A frame over a second has console lines
                (progress.step).  Nothing is named here: a new
                technique module takes part.  A complete probe's choice is remembered per
                scene, light draw, size, renderer, technique set and code version
                (code_version: an edited shader or kernel probes again) in the user's cache
                folder (cache_file), so a later start takes no probe at all (--reprobe
                measures again).
    FrameCosts  the wall time of each technique's frames as measured (the probe's, the
                window's own), scaled to another pixel and light count; a technique never
                measured is estimated from one frame at a reduced size (after one that
                compiles): ESTIMATE_SCALE (1/64 of the pixels) for the reference and the floor,
                whose per-pixel loops do not depend on the resolution, so the estimate is
                close; PLAIN_ESTIMATE_SCALE for a culling technique, for which a reduced size
                over-estimates (its lists grow), the closer to the real size the better.  A
                frame predicted over SLOW_MS is announced in the HUD before it starts.
"""
from __future__ import annotations

from functools import lru_cache
import hashlib
import json
import os
from pathlib import Path
import time

from cpu_prep.camera import frame_camera

from ..errors import FrameTimeout, UserError
from ..techniques.base import visible_lights
from ..techniques.options import cap_policy, stochastic
from . import progress

PROBE_PIXELS = 960 * 540
PROBE_BUDGET_S = float(os.environ.get("LAB_PROBE_BUDGET_S", 6.0))
ESTIMATE_SCALE = 0.125
PLAIN_ESTIMATE_SCALE = 0.5
RANK_SCALE = 0.125          # the probe's ranking frames: 1/64 of its pixels
# A frame predicted over this is announced before it renders (LAB_SLOW_FRAME_S sets it: a
# test's threshold that any frame passes, whatever the machine's speed)
SLOW_MS = float(os.environ.get("LAB_SLOW_FRAME_S", 1.0)) * 1000.0
# A first frame whose GPU passes took this long is its own measure: a software GL compiles a
# technique's shaders on their first dispatch (seconds), a small share of such a frame, and a
# second frame would double a probe of minutes (a million lights on llvmpipe: 216 s a frame)
LONG_FRAME_MS = 30_000.0


def duration(ms: float) -> str:
    """A frame's time as a person reads it: '355 ms', '1.5 s', '395 s'."""
    if ms < 1000.0:
        return f"{ms:.0f} ms"
    return f"{ms / 1000:.1f} s" if ms < 10_000.0 else f"{ms / 1000:.0f} s"


def _scaled(size, scale: float) -> tuple[int, int]:
    return max(8, int(round(size[0] * scale))), max(8, int(round(size[1] * scale)))


def frame_ms(renderer, technique, opts, lights, cam, size,
             deadline: float | None = None) -> tuple[float, float]:
    """(wall ms, GPU passes' ms) of one frame of `technique` at `size` (the renderer is
    left at that size); FrameTimeout past `deadline` (Renderer.render's)."""
    if renderer.size != tuple(size):
        renderer.resize(size)
    t0 = time.perf_counter()
    result = renderer.render(technique, 0, opts, lights=lights, readback=False,
                             camera=frame_camera(cam, *size), deadline=deadline)
    renderer.ctx.finish()
    return (time.perf_counter() - t0) * 1e3, float(sum(result.meta["gpu_ms"].values()))


def timed_frame(renderer, technique, opts, lights, cam, size, deadline: float | None = None) -> float:
    """Wall ms of one frame of `technique` at `size` (the renderer is left at that size)."""
    return frame_ms(renderer, technique, opts, lights, cam, size, deadline)[0]


def _deadline(allow_s: float | None) -> float | None:
    return None if allow_s is None else time.perf_counter() + allow_s


def measured_ms(renderer, technique, opts, lights, cam, size, what: str,
                expect_s: float | None = None, allow_s: float | None = None) -> float:
    """Wall ms of `technique`'s second frame at `size` (the first compiles), or of its first
    when that frame's GPU passes alone took over LONG_FRAME_MS; each frame over a second
    has its console lines (`what`: the step; expect_s: what the first may take, None:
    unknown, said before it).  allow_s: each frame's deadline, from its start (FrameTimeout
    past it; Renderer.render counts the technique's passes, not its build or compiles)."""
    with progress.step(f"{what}, first frame (compiles)", expect_s, unknown=expect_s is None):
        wall, gpu = frame_ms(renderer, technique, opts, lights, cam, size, _deadline(allow_s))
    if gpu > LONG_FRAME_MS:
        return wall
    with progress.step(f"{what}, timed frame", gpu / 1e3):      # the first's wall: its compile too
        return timed_frame(renderer, technique, opts, lights, cam, size, _deadline(allow_s))


class Refusals:
    """Why each technique would refuse the frames the window renders, asked before building
    (Technique.refusal on the counts of base.visible_lights: one cull per cap policy and
    stochastic draw, and per frame size)."""

    def __init__(self, frames):
        self.frames = list(frames)
        self._visible: dict = {}

    def visible(self, k: int, opts) -> int:
        key = (k, cap_policy(opts), stochastic(opts))
        if key not in self._visible:
            self._visible[key] = visible_lights(self.frames[k], opts)
        return self._visible[key]

    def of(self, technique, opts) -> str | None:
        for k, frame in enumerate(self.frames):
            why = technique.refusal(frame, opts, self.visible(k, opts))
            if why:
                return why
        return None


def programs_built(renderer) -> int:
    """How many GL programs the renderer has built so far (0 for one that does not say)."""
    return len(getattr(getattr(renderer, "programs", None), "sources", ()))


def settled_ms(renderer, technique, opts, lights, cam, size, what: str,
               expect_s: float | None = None, allow_s: float | None = None) -> float:
    """Wall ms of a frame at `size` of a technique whose shaders and kernels an earlier
    frame (at another size) compiled: that frame, or a second one when it built new GL
    programs (a variant this size needs: its compile is in the frame) and its GPU passes
    took under LONG_FRAME_MS.  Console lines, and allow_s, as measured_ms's."""
    built = programs_built(renderer)
    with progress.step(what, expect_s, unknown=expect_s is None):
        wall, gpu = frame_ms(renderer, technique, opts, lights, cam, size, _deadline(allow_s))
    if programs_built(renderer) == built or gpu > LONG_FRAME_MS:
        return wall
    with progress.step(f"{what}, again (that frame compiled)", gpu / 1e3):
        return timed_frame(renderer, technique, opts, lights, cam, size, _deadline(allow_s))


def _refusal(refusals: Refusals, t, opts) -> str | None:
    try:
        return refusals.of(t, opts)
    except UserError as exc:
        return str(exc)


def rank(renderer, able, lights, cam, size, allow_s: float | None = None
         ) -> tuple[list[str], dict[str, float], dict[str, str]]:
    """(the names of `able` [(technique, opts)], the likely fastest first, {name: wall ms of
    its ranking frame at `size`}, {name: why it was left out}): two frames each at `size`
    (measured_ms: the first compiles, or is its own measure when over LONG_FRAME_MS); one
    that refuses there (its refusal() at this size, or its build) comes after the ranked
    ones, in the given order; one whose frame runs past `allow_s` (each frame's deadline:
    fastest() says why) is left out, with its console line."""
    refusals = Refusals([renderer.frame_input(0, 1, lights, frame_camera(cam, *size))])
    ranked: dict[str, float] = {}
    unranked: list[str] = []
    over: dict[str, str] = {}
    last_s = None
    for k, (t, opts) in enumerate(able, 1):
        if _refusal(refusals, t, opts) is None:
            try:
                ms = measured_ms(renderer, t, opts, lights, cam, size,
                                 f"ranking {k}/{len(able)}: {t.name} at {size[0]}x{size[1]}", last_s,
                                 allow_s)
            except FrameTimeout as exc:
                over[t.name] = (f"its ranking frame at {size[0]}x{size[1]} ran past the probe's "
                                f"{allow_s:g} s deadline ({str(exc).removeprefix(t.name + ': ')})")
                progress.say(f"probe: left out {t.name}: {over[t.name]}")
                continue
            except UserError:
                pass
            else:
                ranked[t.name], last_s = ms, ms / 1e3
                continue
        unranked.append(t.name)
    order = sorted(ranked, key=ranked.get) + unranked      # stable: ties in the given order
    progress.say(f"probe: ranked at {size[0]}x{size[1]}: "
                 + ", ".join(f"{n} {duration(ranked[n])}" if n in ranked else f"{n} (refused there)"
                             for n in order)
                 + "".join(f", {n} (over the {allow_s:g} s deadline)" for n in over))
    return order, ranked, over


def fastest(renderer, candidates, opts_of, lights, cam, max_pixels: int = PROBE_PIXELS,
            budget_s: float | None = None):
    """(name of the fastest candidate, {name: wall ms at the probe size}, probe size,
    names not probed for want of time, {name: why it refused}).  `opts_of(technique)`
    gives its options.  A candidate that refuses (its options; a limit its refusal()
    names at the probe's size or the window's, then it is never built; a limit only its
    build meets) is left out with its line.  Two or more that take the frame are ranked
    first (rank(): a frame each at RANK_SCALE of the probe size) and timed at the probe
    size in that order (settled_ms) within `budget_s` from the first of those frames; a
    lone one, or one that refused at the ranking's size, is timed with measured_ms (its
    first frame compiles).  `budget_s` None: PROBE_BUDGET_S.  The renderer is back at its
    size afterwards."""
    budget_s = PROBE_BUDGET_S if budget_s is None else budget_s
    full = renderer.size
    size = _scaled(full, min(1.0, (max_pixels / (full[0] * full[1])) ** 0.5))
    sizes = [size] + ([full] if tuple(full) != tuple(size) else [])
    refusals = Refusals(renderer.frame_input(0, 1, lights, frame_camera(cam, *s)) for s in sizes)
    times: dict[str, float] = {}
    skipped: list[str] = []
    refused: dict[str, str] = {}
    able = {}                                           # name: (technique, options), given order
    for t in candidates:
        try:
            opts = opts_of(t)
        except UserError as exc:
            refused[t.name] = str(exc)
            continue
        why = _refusal(refusals, t, opts)
        if why:
            refused[t.name] = why
        else:
            able[t.name] = (t, opts)
    small = _scaled(size, RANK_SCALE)
    line = f"{len(able)} techniques at {size[0]}x{size[1]}"
    if len(able) > 1:
        line += f", the likely fastest first (ranked by a frame each at {small[0]}x{small[1]})"
    progress.say(f"probe: timing {line}, {len(lights):,} lights "
                 f"(--technique NAME starts without the probe)")
    try:
        order, ranked, over = rank(renderer, list(able.values()), lights, cam, small, budget_s) \
            if len(able) > 1 else (list(able), {}, {})
        if not order:                                   # every ranking frame ran past its deadline:
            order, over = list(over), {}                # timed all the same, the first whole
        t0, last, last_s = time.perf_counter(), None, None  # the budget: after every compile frame
        for k, name in enumerate(order, 1):
            t, opts = able[name]
            expect = times[last] * ranked[name] / max(ranked[last], 1e-3) \
                if last is not None and name in ranked else None
            if times and (time.perf_counter() - t0 > budget_s
                          or (expect is not None and expect > budget_s * 1e3)):
                skipped.append(name)
                continue
            what = f"probe {k}/{len(order)}: {name} at {size[0]}x{size[1]}"
            # the first timed frame has no deadline (the start needs one measure, and the
            # window renders it anyway); a later one stops when it alone overruns the budget,
            # the frame the expectation above would not have started
            allow_s = budget_s if times else None
            try:
                if name in ranked:
                    ms = settled_ms(renderer, t, opts, lights, cam, size, what,
                                    None if expect is None else expect / 1e3, allow_s)
                else:
                    ms = measured_ms(renderer, t, opts, lights, cam, size, what, last_s, allow_s)
            except FrameTimeout as exc:
                skipped.append(name)
                progress.say(f"probe: {name} not timed: its frame at {size[0]}x{size[1]} ran past the "
                             f"probe's {budget_s:g} s budget ({str(exc).removeprefix(name + ': ')})")
                continue
            except UserError as exc:
                refused[name] = str(exc)
                continue
            times[name], last_s = ms, ms / 1e3
            if name in ranked:
                last = name
        skipped += list(over)                       # the slowest of all: left out for time too
    finally:
        renderer.resize(full)
    refused = {t.name: refused[t.name] for t in candidates if t.name in refused}   # given order
    if not times:
        return None, times, size, skipped, refused
    return min(times, key=times.get), times, size, skipped, refused


ROOT = Path(__file__).resolve().parents[2]
COST_SOURCES = ("glsl/*", "cpu_prep/*.py", "app/pipeline/*.py", "app/techniques/*.py", "app/techniques/*/*",
                "app/gpu_build/*.comp", "app/gpu_build/*.glsl", "scenes/*.py")


@lru_cache(maxsize=None)
def code_version(root: Path = ROOT) -> str:
    """A hash of the sources a frame's cost depends on (shaders, CPU stage, pipeline,
    techniques, the scene builders and readers): a remembered choice is only reused by the
    code that measured it."""
    h = hashlib.sha1()
    for pattern in COST_SOURCES:
        for p in sorted(root.glob(pattern)):
            if p.is_file() and p.suffix != ".pyc":      # not a folder's __pycache__
                h.update(str(p.relative_to(root)).encode() + p.read_bytes())
    return h.hexdigest()[:16]


def file_stamp(scene: str) -> list | None:
    """Size and modification time of a scene file (None for a builtin name): an edited
    file probes again.  Only the file named (not the meshes, npz or glTF buffers it
    refers to: --reprobe after editing those)."""
    try:
        st = Path(scene).stat()
    except OSError:
        return None
    return [st.st_size, st.st_mtime_ns]


def start_key(args, lights: int, size, renderer: str, candidates, given: dict) -> str:
    """The remembered probe's key: scene (and its file's stamp), light draw, size, renderer,
    candidate techniques, the options given, and the code version."""
    return json.dumps([args.scene, lights, args.seed, args.distribution, list(size), renderer,
                       sorted(candidates), sorted(given.items()), code_version(),
                       file_stamp(args.scene)], default=str)


def cache_file() -> Path:
    """The start-up probe's memory: $LAB_CACHE_DIR, else $XDG_CACHE_HOME (or ~/.cache)/many-light-lab,
    /window-start.json."""
    root = os.environ.get("LAB_CACHE_DIR")
    if not root:
        root = str(Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "many-light-lab")
    return Path(root) / "window-start.json"


def remembered(key: str) -> dict | None:
    try:
        return json.loads(cache_file().read_text()).get(key)
    except (OSError, ValueError, AttributeError):
        return None


def remember(key: str, choice: dict) -> None:
    """Keep the probe's choice (best effort: an unwritable cache folder is no error)."""
    path = cache_file()
    try:
        data = json.loads(path.read_text()) if path.is_file() else {}
        if not isinstance(data, dict):
            data = {}
    except (OSError, ValueError):
        data = {}
    data[key] = choice
    while len(data) > 64:                       # a small file: the oldest entries go
        data.pop(next(iter(data)))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data, indent=1) + "\n")
    except OSError:
        pass


class FrameCosts:
    """Measured wall ms per technique, with the pixels and lights it was measured at."""

    def __init__(self):
        self.known: dict[str, tuple[float, int, int]] = {}
        self.announced: set = set()

    def slow(self, renderer, plan, lights_key, lights, cam) -> list[str]:
        """Of the (technique, opts) a frame renders, the ones predicted over SLOW_MS at the
        renderer's size, each said once per light draw and size."""
        size = renderer.size
        out = []
        for t, opts in plan:
            k = (t.name, lights_key, size)
            if k in self.announced:
                continue
            self.announced.add(k)
            try:
                ms = self.estimate(renderer, t, opts, lights, cam)
            except UserError:
                continue
            if ms > SLOW_MS:
                out.append(f"{t.name} needs about {ms / 1000:.1f} s a frame at {size[0]}x{size[1]}")
        return out

    def record(self, name: str, ms: float, pixels: int, lights: int) -> None:
        self.known[name] = (float(ms), int(pixels), int(lights))

    def predict(self, name: str, pixels: int, lights: int) -> float | None:
        """ms scaled linearly in pixels and in lights (an upper bound for a culling
        technique, exact for brute-force loops); None when never measured."""
        k = self.known.get(name)
        if k is None:
            return None
        ms, p0, l0 = k
        return ms * pixels / max(p0, 1) * max(lights, 1) / max(l0, 1)

    def estimate(self, renderer, technique, opts, lights, cam) -> float:
        """Predicted ms at the renderer's size: measured, or from one frame at
        ESTIMATE_SCALE of the size (recorded as measured there)."""
        w, h = renderer.size
        got = self.predict(technique.name, w * h, len(lights))
        if got is not None:
            return got
        full = renderer.size
        small = _scaled(full, ESTIMATE_SCALE if technique.role != "technique" else PLAIN_ESTIMATE_SCALE)
        # what its frames may take, for the console: the slowest technique measured so far
        others = [self.predict(k, small[0] * small[1], len(lights)) for k in self.known]
        try:
            ms = measured_ms(renderer, technique, opts, lights, cam, small,
                             f"estimating {technique.name}'s frame at {small[0]}x{small[1]}",
                             max(others) / 1e3 if others else None)
        finally:
            renderer.resize(full)
        self.record(technique.name, ms, small[0] * small[1], len(lights))
        return self.predict(technique.name, w * h, len(lights))


def choose_start(args, renderer, candidates, options, lights_of, camera, costs: FrameCosts):
    """(the starting technique, lines saying why: how it was chosen, then each technique
    the probe left out for a limit, "skipped NAME: the limit"): the only candidate, the one
    the last probe chose for the same scene (and file), lights, size, renderer, techniques
    and code version, or the fastest of the candidates now (fastest()); the times measured
    go into `costs`.  lights_of(): the scene's lights as the window draws them."""
    if len(candidates) == 1:
        return candidates[0], [f"{candidates[0]}: the only technique that takes the given options"]
    from ..techniques import REGISTRY
    n = len(lights_of())
    key = start_key(args, n, renderer.size, renderer.limits.renderer, candidates, options.given)
    got = None if args.reprobe else remembered(key)
    if got and got.get("technique") in candidates:
        name, times, size = got["technique"], got.get("times", {}), tuple(got.get("size", renderer.size))
        refused, skipped = got.get("refused", {}), []
        how = f"at the last probe, {got.get('when', '?')}; --reprobe measures again"
    else:
        t0 = time.perf_counter()
        name, times, size, skipped, refused = fastest(
            renderer, [REGISTRY[c] for c in candidates], lambda t: options.for_technique(t)[0],
            lights_of(), camera)
        if name is None:
            raise UserError(f"no technique can render {n:,} lights of this scene here: "
                            f"{every_refusal(refused)}")
        how = f"probe at {size[0]}x{size[1]}, {time.perf_counter() - t0:.1f} s"
        if skipped:
            how += f"; not probed for time: {', '.join(skipped)}"
        else:
            remember(key, {"technique": name, "times": times, "size": list(size), "refused": refused,
                           "when": time.strftime("%Y-%m-%d %H:%M")})
    for k, ms in times.items():
        costs.record(k, ms, size[0] * size[1], n)
    ranked = ", ".join(f"{k} {duration(v)}" for k, v in sorted(times.items(), key=lambda kv: kv[1]))
    which = "the fastest of those probed" if skipped else "the fastest exact technique here"
    return name, ([f"started on {name}, {which} ({ranked}; {how})"]
                  + [f"skipped {k}: {why.removeprefix(k + ': ')}" for k, why in refused.items()])


def every_refusal(refused: dict[str, str]) -> str:
    """The candidates' refusals in one line: the limit once when they all meet the same."""
    if len(set(refused.values())) == 1:
        return f"{', '.join(refused)}: {next(iter(refused.values()))}"
    return "; ".join(f"{k}: {why}" for k, why in refused.items())
