"""app.cli: every technique's declared options as flags, each checked as declared."""
from __future__ import annotations

import argparse

import pytest

from app import cli
from app.techniques import REGISTRY


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(exit_on_error=False)
    cli.add_option_args(p)
    return p


def test_a_choice_flag_takes_its_name_or_its_number():
    names = REGISTRY["fptl"].Options.spec("fptl_variant").choices
    assert parser().parse_args(["--fptl-variant", names[1]]).fptl_variant == 1
    assert parser().parse_args(["--fptl-variant", "3"]).fptl_variant == 3
    with pytest.raises(argparse.ArgumentError, match="must be one of 0 "):
        parser().parse_args(["--fptl-variant", "4"])


def test_a_flag_not_given_is_absent():
    assert not hasattr(parser().parse_args([]), "fptl_variant")
