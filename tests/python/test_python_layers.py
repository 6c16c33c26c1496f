"""The Python package has no import cycles (docs/architecture.md, Python): every
`import` of a vpffd module, at module level or inside a function, is followed, and
the graph must be acyclic but for the one display hook named below. The C++ side has
its own check (test_architecture.py)."""
import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "python" / "vpffd"

# Jupyter looks for _repr_png_ on the object's class, so Mesh carries it and imports
# the notebook layer (rendering, Embree) only when a notebook shows a mesh. This is
# the one edge that points up the layers.
HOOKS = {("vpffd.mesh", "vpffd.notebook")}


def modules():
    out = {}
    for p in PACKAGE.rglob("*.py"):
        parts = p.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = p
    return out


def import_graph():
    mods = modules()
    edges = {m: set() for m in mods}
    for m, p in mods.items():
        package = m if p.name == "__init__.py" else m.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(p.read_text())):
            targets = []
            if isinstance(node, ast.ImportFrom):
                base = package.split(".")
                if node.level:
                    base = base[:len(base) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                if node.module:
                    targets.append(target)
                targets += [f"{target}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            edges[m] |= {t for t in targets if t in mods and t != m}
    return edges


def cycles(edges):
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges[v]:
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
                found.append(sorted(comp))

    for v in list(edges):
        if v not in index:
            visit(v)
    return found


def test_no_import_cycles_but_the_display_hook():
    edges = import_graph()
    for a, b in HOOKS:
        assert b in edges[a], f"the hook {a} -> {b} is gone: drop it from HOOKS"
        edges[a].discard(b)
    assert cycles(edges) == []


def test_the_checker_sees_cycles():
    edges = import_graph()
    assert cycles(edges), "the display hook's cycle should be found when it is not excused"
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == [["a", "b", "c"]]


def test_the_library_never_imports_the_application():
    edges = import_graph()
    for m, targets in edges.items():
        if not m.startswith("vpffd.cli") and m not in ("vpffd.demo", "vpffd.benchmark", "vpffd.__main__"):
            assert not {t for t in targets if t.startswith("vpffd.cli")}, m
