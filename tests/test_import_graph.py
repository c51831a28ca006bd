"""No import cycles anywhere in the project's packages, counting imports inside functions too
(a cycle postponed into a function body is still a cycle), and importing a module imports its
packages' __init__ first.  The CPU stage and the scenes know nothing of OpenGL or the app."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("app", "cpu_prep", "scenes")


def modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in (ROOT / pkg).rglob("*.py"):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """Project modules `name` imports (absolute, resolved), anywhere in its body."""
    is_pkg = path.name == "__init__.py"
    here = name.split(".") if is_pkg else name.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = here[:len(here) - node.level + 1] if node.level else []
            mod = ".".join(base + ([node.module] if node.module else []))
            targets = [mod] + [f"{mod}.{a.name}" for a in node.names]
        else:
            continue
        for t in targets:
            while t and t not in known:
                t = t.rpartition(".")[0]
            if t:
                found.add(t)
    # importing a.b.c runs a/__init__ and a/b/__init__ first (unless we are inside them)
    out = set()
    for t in found:
        parts = t.split(".")
        for k in range(1, len(parts) + 1):
            p = ".".join(parts[:k])
            if p in known and not (name == p or name.startswith(p + ".")):
                out.add(p)
    out.discard(name)
    return out


def graph() -> dict[str, set[str]]:
    mods = modules()
    return {n: imports_of(n, p, set(mods)) for n, p in mods.items()}


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(g[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycles():
    assert cycles(graph()) == []


def test_the_checker_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_layers():
    """cpu_prep and scenes never import app; scenes never imports cpu_prep; the pipeline
    never imports the techniques, the tools or the window."""
    g = graph()
    for mod, deps in g.items():
        if mod.startswith(("cpu_prep", "scenes")):
            assert not any(d.startswith("app") for d in deps), (mod, deps)
        if mod.startswith("scenes"):
            assert not any(d.startswith("cpu_prep") for d in deps), (mod, deps)
        if mod.startswith("app.pipeline"):
            assert all(d.startswith(("app.pipeline", "app.errors", "cpu_prep", "scenes"))
                       for d in deps), (mod, deps)


def test_technique_frames_stay_free_of_the_model_and_report():
    """A technique's frame (its folder's __init__) is what the renderer needs: the cost model
    and the report find its replay and paper modules (app.techniques.parts), never the
    other way round, and the frame stays short."""
    g = graph()
    for path in sorted((ROOT / "app" / "techniques").glob("*/__init__.py")):
        name = f"app.techniques.{path.parent.name}"
        assert not any(d.startswith(("app.model", "app.report")) for d in g[name]), (name, g[name])
        assert len(path.read_text().splitlines()) <= 400, name


def test_headless_tools_stand_below_the_window():
    """Capture and the benchmark run without a display: they import nothing of the window
    (the camera-path format is scenes.camera_path, the shared flags app.cli, the views'
    definitions app.views)."""
    g = graph()
    tools = [m for m in g if m == "app.capture" or m.startswith("app.bench")]
    assert "app.capture" in tools and "app.bench" in tools
    for mod in tools:
        assert not any(d.startswith("app.window") for d in g[mod]), (mod, g[mod])
