"""The choice kind of option (app.techniques.options.choice): its names, written once, make
its help, its range, its study values and the name its stats give; a bad value is a one-line
UserError listing the choices."""
from __future__ import annotations

from dataclasses import dataclass

import pytest

from app.errors import UserError
from app.techniques import REGISTRY
from app.techniques.options import TechniqueOptions, choice, option

NAMES = ("plain", "fast", "exact")


@dataclass(frozen=True)
class Opts(TechniqueOptions):
    mode: int = choice("fast", NAMES, "how to walk", study=True)
    other: int = option(1, "a plain int", lo=0, hi=9)


def test_names_make_help_range_and_study():
    s = Opts.spec("mode")
    assert s.kind is int and s.default == 1 and s.choices == NAMES
    assert s.help == "how to walk: 0 plain, 1 fast, 2 exact"
    assert (s.lo, s.hi) == (0, 2)
    assert s.study == (0, 1, 2)
    assert Opts().choice_name("mode") == "fast"


def test_a_choice_takes_its_name_or_its_number():
    assert Opts.make({"mode": "exact"}).mode == 2
    assert Opts.make({"mode": "0"}).mode == 0
    assert Opts.make({"mode": 2}).choice_name("mode") == "exact"


@pytest.mark.parametrize("bad", [3, -1, "slow", 1.5, True, None])
def test_a_bad_value_is_one_line_naming_the_choices(bad):
    with pytest.raises(UserError) as e:
        Opts.make({"mode": bad}, "tech")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("tech: --mode must be one of 0 plain, 1 fast, 2 exact")


def test_the_default_must_be_a_name_and_names_unique():
    with pytest.raises(ValueError):
        choice("slow", NAMES, "x")
    with pytest.raises(ValueError):
        choice("a", ("a", "a"), "x")


def test_a_plain_option_has_no_choices():
    s = Opts.spec("other")
    assert s.choices == () and s.label(3) == "3"


def test_the_techniques_variants_are_choices():
    """fptl's variant and the tree build name their values once; stats read the names."""
    from app.techniques import fptl
    from cpu_prep import tree as treemod
    assert REGISTRY["fptl"].Options.spec("fptl_variant").choices == fptl.VARIANTS
    for t in ("tree", "hybrid"):
        assert REGISTRY[t].Options.spec("tree_build").choices == tuple(treemod.BUILDS.values())
    o = REGISTRY["fptl"].Options.make({"fptl_variant": "coarse per cell"})
    assert fptl.variant_flags(o.fptl_variant) == (False, True)
