"""The suite's own layout: pytest's default import mode ("prepend", no __init__.py in the
test folders) imports a test module by its base name, so two test_x.py in different folders
stop the suite at collection; this names them instead."""
from collections import Counter
from pathlib import Path


def test_test_module_names_are_unique():
    names = Counter(p.name for p in Path(__file__).parent.rglob("test_*.py"))
    assert not [n for n, k in names.items() if k > 1], names.most_common(3)


def test_shared_reference_scopes_name_real_tests():
    """conftest's SHARED_REFERENCE patterns match the node ids of the tests that share a
    reference frame: a renamed test or parameter would otherwise spread them over workers
    again, each rendering the reference itself."""
    import subprocess
    import sys
    from conftest import shared_reference_scope
    from scenes import BUILTIN_SCENES
    root = Path(__file__).parent
    ids = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-n", "0",
                          str(root / "app/techniques/test_exactness.py"),
                          str(root / "app/techniques/test_tree_options.py")],
                         capture_output=True, text=True, cwd=root.parent).stdout.split()
    scopes = Counter(shared_reference_scope(i) for i in ids if "::" in i)
    for name in BUILTIN_SCENES:       # the exactness check's uniform draw and the tree options
        assert scopes[f"reference {name}"] == 2, (name, scopes)
    assert scopes["reference arena 4096"] >= 10, scopes


def test_grouped_modules_exist():
    """conftest's GROUPED paths name real test modules: a moved or renamed one would
    otherwise drop out of its group silently, its expensive fixture run on every worker."""
    from conftest import GROUPED
    root = Path(__file__).parent.parent
    assert [p for p in GROUPED if not (root / p).is_file()] == []


def test_no_test_module_imports_another():
    """A test module imported as a library is imported twice (as its base name by pytest, as
    tests.x.test_y by the importer): what tests share lives in helper modules instead."""
    import re
    root = Path(__file__).parent
    bad = [str(p.relative_to(root)) for p in root.rglob("test_*.py")
           if re.search(r"^\s*(from tests\.\S*\btest_\w+ import|from tests\.\S* import .*\btest_\w+)",
                        p.read_text(), re.M)]
    assert bad == [], bad
