"""The registry: every module of app/techniques is imported, and a technique registers itself
at its place (class X(Technique, register_at=N)), so adding one is adding its module."""
from __future__ import annotations

import sys
import textwrap

import pytest

from app.techniques import REGISTRY, Technique, discover, register, unregister

# The order reports and tests list the techniques in.
ORDER = ("brute", "tiled", "clustered", "tree", "hybrid", "zbin", "fptl", "raster", "perfect")


def test_the_registry_keeps_its_order():
    assert tuple(REGISTRY)[:len(ORDER)] == ORDER


MODULE = '''
from app.techniques.base import Technique, prepare, shading_passes


class Mine(Technique, register_at={at}):
    name = "{name}"
    summary = "a technique in a module of its own"

    def build(self, frame, opts):
        return prepare(frame)

    def passes(self, build, opts):
        return shading_passes(build, "shade_brute.comp", longest=len(build.lights))
'''


@pytest.fixture
def plugins(tmp_path, monkeypatch):
    """A package of technique modules outside the tree, importable; its techniques and
    modules are gone afterwards."""
    pkg = tmp_path / "labplugins"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    monkeypatch.syspath_prepend(str(tmp_path))
    before = set(REGISTRY)
    yield pkg
    for name in set(REGISTRY) - before:
        unregister(name)
    for mod in [m for m in sys.modules if m == "labplugins" or m.startswith("labplugins.")]:
        del sys.modules[mod]


def test_a_new_module_registers_by_itself_at_its_place(plugins):
    (plugins / "mine.py").write_text(textwrap.dedent(MODULE.format(at=25, name="mine")))
    (plugins / "later.py").write_text(textwrap.dedent(MODULE.format(at=95, name="later")))
    assert discover("labplugins") == ["later", "mine"]           # name order
    names = tuple(REGISTRY)
    assert names.index("tiled") < names.index("mine") < names.index("clustered")
    assert names.index("perfect") < names.index("later")
    assert type(REGISTRY["mine"]).__name__ == "Mine"


def test_a_subclass_without_a_place_is_not_registered():
    class Helper(Technique):
        name = "helper"
    assert "helper" not in REGISTRY
    register(Helper())                 # by hand (the tests' throwaway techniques): last
    try:
        assert tuple(REGISTRY)[-1] == "helper"
    finally:
        unregister("helper")


def test_a_name_is_registered_once():
    with pytest.raises(ValueError):
        register(type(REGISTRY["brute"])())
