"""--cap-policy on the list techniques: a capped frame differs from brute on purpose, by
exactly the lights its policy dropped; its meta says so, and the exactness check counts the
loss (never a pass, never a plain failure).  Which lights go is held to each engine's rule
written here (budgets per type group, scene order or distance from the eye) on a scene past
every view cap, the frame to brute without exactly those.  `none` changes nothing."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.exactness import IntendedLoss, Mismatch, check, differing
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, with_role
from app.techniques.options import CapOptions
from cpu_prep import caps
from cpu_prep.camera import look_at
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT
from tests.helpers import CAMERA, make_scene, random_lights, random_shapes

ROOT = Path(__file__).resolve().parents[3]
CAPPED = [n for n, t in REGISTRY.items() if issubclass(t.Options, CapOptions)]
SIZE = (64, 36)


@pytest.fixture(scope="module")
def capped_scene():
    rng = np.random.default_rng(21)
    # 60 lights over the floor and boxes in view, large enough to light many pixels
    return make_scene(random_lights(rng, 60, (-10, 0, -30), (10, 6, 5), radius=(2.0, 8.0)),
                      size=SIZE)


def test_the_list_techniques_take_the_cap_and_the_reference_does_not():
    assert {"tiled", "clustered", "zbin", "fptl", "hybrid"} <= set(CAPPED)
    assert with_role("reference").name not in CAPPED
    assert "perfect" not in CAPPED


def test_a_capped_frame_is_an_intended_loss_of_exactly_the_dropped_lights(gl, capped_scene):
    ref_t = with_role("reference")
    with Renderer(capped_scene) as r:
        ref = r.render(ref_t)
        for name in CAPPED:
            t = REGISTRY[name]
            opts = t.Options.make({"cap_policy": "urp-16"})
            res = r.render(t, opts=opts)
            stats = res.meta["stats"]
            assert stats["cap_policy"] == "urp-16" and stats["visible_lights"] == 16, name
            assert stats["capped_lights"] == len(res.build.capped_ids) > 0, name
            assert res.meta["options"]["cap_policy"] == caps.NAMES.index("urp-16")
            m = check(res, ref, r, t, ref_t, {"opts": opts})
            assert isinstance(m, IntendedLoss), f"{name}: {m.message() if m else 'a pass'}"
            # the dropped lights light pixels here: a counted loss, and only a loss
            assert m.pixels > 0 and m.contributions >= m.pixels and m.lights == stats["capped_lights"]
            assert (res.contrib_count <= ref.contrib_count).all(), name
            assert m.message().startswith(f"intended loss: {m.pixels} pixels, {m.lights} lights "
                                          f"dropped by urp-16")


def test_no_cap_changes_nothing(gl, capped_scene):
    ref_t = with_role("reference")
    with Renderer(capped_scene) as r:
        ref = r.render(ref_t)
        for name in ("tiled", "clustered"):
            res = r.render(REGISTRY[name], opts={"cap_policy": "none"})
            assert "cap_policy" not in res.meta["stats"] and res.build.capped_ids is None
            assert check(res, ref) is None
            # a policy over more lights than the frame has drops none: exact, still counted 0
            res = r.render(REGISTRY[name], opts={"cap_policy": "filament-256"})
            assert res.meta["stats"]["capped_lights"] == 0
            m = check(res, ref, r, REGISTRY[name], ref_t, {"opts": {"cap_policy": "filament-256"}})
            assert isinstance(m, IntendedLoss) and m.pixels == 0 and m.lights == 0


# ---- who is dropped: each engine's budgets and order, written here from its source
# (docs/research/accuracy_policies.md), not read from cpu_prep.caps ----------------------

P, S, C, B = LIGHT_POINT, LIGHT_SPOT, LIGHT_CAPSULE, LIGHT_BOX
ENGINES = {   # policy: ((types of a budget, most kept), ...), order
    "godot-512": ((((P,), 512), ((S,), 512), ((C,), 512), ((B,), 512)), "scene"),
    "hdrp-view": ((((P, S, B), 512), ((C,), 64)), "scene"),
    "filament-256": ((((P, S, C, B), 256),), "nearest"),
}


def expected_drops(policy: str, lights) -> list[int]:
    """The scene ids an engine's policy drops when every light is visible: past each budget,
    the last in scene order, or the farthest from the eye (ties: the higher id)."""
    budgets, order = ENGINES[policy]
    eye = np.asarray(CAMERA.position, np.float64)
    far = np.linalg.norm(lights["position"].astype(np.float64) - eye, axis=1)
    out = []
    for types, most in budgets:
        ids = np.flatnonzero(np.isin(lights["type"], types))
        ranked = ids if order == "scene" else ids[np.lexsort((ids, far[ids]))]
        out += ranked[most:].tolist()
    return sorted(out)


@pytest.fixture(scope="module")
def crowd():
    """700 small lights of the four shapes in scene order shuffled (560 points: past
    Godot's 512 of a type and, with the spots and boxes, HDRP's 512 punctual; 80 capsules:
    past HDRP's 64 area lights), every one wholly in view; a tiny frame (the caps act on
    the lights, not the pixels)."""
    rng = np.random.default_rng(8)
    L = np.concatenate([random_shapes(rng, n, (-4, 0.5, -14), (4, 3, -4), radius=(0.3, 0.8),
                                      length=(0.0, 1.0), extent=(0.1, 0.5), shares=np.eye(4)[t])
                        for t, n in ((P, 560), (S, 40), (C, 80), (B, 20))])
    return make_scene(L[rng.permutation(len(L))], size=(32, 24))


@pytest.mark.parametrize("policy", list(ENGINES))
def test_the_engines_view_caps_drop_the_lights_their_order_says(gl, crowd, policy):
    want = expected_drops(policy, crowd.lights)
    assert len(want) > 0
    ref_t = with_role("reference")
    without = caps.without(crowd.lights, want, look_at(CAMERA.position, CAMERA.target, CAMERA.up))
    with Renderer(crowd) as r:
        ref = r.render(ref_t)
        assert ref.meta["stats"]["visible_lights"] == len(crowd.lights)     # all in view
        intended = r.render(ref_t, lights=without)
        assert (intended.contrib_count < ref.contrib_count).any()           # the drops show
        for name in CAPPED:
            t = REGISTRY[name]
            opts = t.Options.make({"cap_policy": policy})
            res = r.render(t, opts=opts)
            got = sorted(int(i) for i in res.build.capped_ids)
            assert got == want, f"{name}: dropped {got[:8]}... expected {want[:8]}..."
            assert res.meta["stats"]["capped_lights"] == len(want), name
            bad = differing(res, intended)     # brute without exactly those, at every pixel
            assert not bad.any(), f"{name} under {policy}: {bad.sum()} pixels differ"
            assert isinstance(check(res, ref, r, t, ref_t, {"opts": opts}), IntendedLoss), name


class LosesMore(type(REGISTRY["tiled"])):
    """tiled under a cap that also loses a kept light: a failure, not an intended loss."""
    name = "loses-more"

    def build(self, frame, opts):
        b = super().build(frame, opts)
        b.buffers["lights"] = b.buffers["lights"].copy()
        b.buffers["lights"]["pos_radius"][0, 3] = 0.0         # the nearest kept light: no reach
        return b


def test_a_loss_beyond_the_cap_is_a_plain_failure(gl, capped_scene):
    ref_t, t = with_role("reference"), LosesMore()
    with Renderer(capped_scene) as r:
        ref = r.render(ref_t)
        opts = t.Options.make({"cap_policy": "urp-16"})
        res = r.render(t, opts=opts)
        m = check(res, ref, r, t, ref_t, {"opts": opts})
    assert isinstance(m, Mismatch), m
    assert "without the" in m.message() and "urp-16" in m.message()
    assert m.missing and not m.extra


def capture(*args):
    return subprocess.run([sys.executable, "-m", "app.capture", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def test_capture_check_reports_the_intended_loss(tmp_path):
    r = capture("--scene", "hangar", "--technique", "clustered", "--lights", "80", "--size",
                "64x36", "--cap-policy", "urp-16", "--check", str(tmp_path / "chk"),
                "--dump", str(tmp_path / "f.npz"))
    assert r.returncode == 3, r.stderr              # neither exact (0) nor a failure (1)
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("intended loss: ") and "lights dropped by urp-16" in line, line
    pixels = int(line.split("intended loss: ")[1].split(" pixels")[0])
    assert pixels > 0 and "exact:" not in r.stderr and "not exact" not in r.stderr
    from app.dump import read_dump
    stats = read_dump(tmp_path / "f.npz")["meta"]["stats"]
    assert stats["cap_policy"] == "urp-16" and stats["capped_lights"] > 0


@pytest.mark.parametrize("args, says", [
    (("--technique", "tiled", "--cap-policy", "godot-9"), "--cap-policy must be one of 0 none"),
    (("--technique", "brute", "--cap-policy", "urp-16"), "--cap-policy is not an option"),
    (("--technique", "zbin", "--cap-policy", "hdrp-fptl-24"), "only fptl's list build takes it"),
])
def test_bad_cap_policies_are_one_line_and_exit_2(args, says):
    r = capture("--scene", "arena", "--lights", "8", "--size", "16x16", *args)
    assert r.returncode == 2 and says in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_every_policy_name_is_taken_on_the_command_line():
    from app import cli
    from app.capture import build_parser
    for k, name in enumerate(caps.NAMES):       # the per-tile caps by fptl's list build only
        t = "fptl" if caps.per_tile(name) else "zbin"
        args = build_parser().parse_args(["--technique", t, "--cap-policy", name])
        assert cli.options_for(REGISTRY[t], args).cap_policy == k
