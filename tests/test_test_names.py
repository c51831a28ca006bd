"""The suite's own layout: pytest's default import mode ("prepend", no __init__.py in the
test folders) imports a test module by its base name, so two test_x.py in different folders
stop the suite at collection; this names them instead."""
from collections import Counter
from pathlib import Path


def test_test_module_names_are_unique():
    names = Counter(p.name for p in Path(__file__).parent.rglob("test_*.py"))
    assert not [n for n, k in names.items() if k > 1], names.most_common(3)
