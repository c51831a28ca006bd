"""The display's options are declared once (app.display.DISPLAY): the window's and
capture's command lines and the panel take the same ranges.  No GL."""
from __future__ import annotations

import math

import pytest

from app.errors import UserError
from app.techniques import REGISTRY
from app.display import DISPLAY, DISPLAY_FLAGS
from app.given_options import GivenOptions
from app.window.panel import LabState, Panel


def parsers():
    from app import capture
    from app.window import launch
    return {"window": launch.build_parser(), "capture": capture.build_parser()}


def panel():
    state = LabState(REGISTRY, technique="clustered", options=GivenOptions({}), lights=64)
    return state, Panel(state)


def cli_takes(parser, flag: str, value: float) -> bool:
    try:
        parser.parse_args([flag, repr(value)])
    except SystemExit as exc:
        assert exc.code == 2
        return False
    return True


def panel_takes(name: str, value: float) -> bool:
    state, p = panel()
    key, shown = ("exposure_ev", math.log2(value) if value > 0 else -math.inf) if name == "exposure" \
        else (name, value)
    try:
        p.apply(key, repr(shown))
    except UserError:
        return False
    return True


@pytest.mark.parametrize("name", DISPLAY_FLAGS)
def test_command_lines_and_panel_take_the_same_range(name):
    spec = DISPLAY[name]
    inside = [spec.lo, spec.hi] if spec.lo > 0 else [spec.lo, spec.hi, (spec.lo + spec.hi) / 2]
    outside = [spec.lo * 0.5 if spec.lo > 0 else -1.0, spec.hi * 2]
    for parser in parsers().values():
        assert [cli_takes(parser, spec.flag, v) for v in inside] == [True] * len(inside), spec.flag
        assert [cli_takes(parser, spec.flag, v) for v in outside] == [False] * len(outside), spec.flag
    assert [panel_takes(name, v) for v in inside] == [True] * len(inside)
    assert [panel_takes(name, v) for v in outside] == [False] * len(outside)


def test_panel_controls_are_the_declared_specs():
    state, p = panel()
    controls = {c.key: c for c in p.controls()}
    for name in ("ambient", "heat_max", "split_at"):
        c, spec = controls[name], DISPLAY[name]
        assert (c.lo, c.hi) == (spec.lo, spec.hi) and spec.help in c.help
        assert (spec.flag in c.help) == (name in DISPLAY_FLAGS)        # split_at has no flag
    ev = controls["exposure_ev"]
    assert (2 ** ev.lo, 2 ** ev.hi) == pytest.approx((DISPLAY["exposure"].lo, DISPLAY["exposure"].hi))


def test_command_line_help_gives_the_range_and_auto():
    text = parsers()["window"].format_help()
    assert "--ambient" in text and "'auto'" in text
    args = parsers()["window"].parse_args(["--exposure", "auto", "--ambient", "0.5"])
    assert args.exposure == "auto" and args.ambient == 0.5
    assert parsers()["capture"].parse_args(["--exposure", "2"]).exposure == 2.0
