"""The Python package's layers (issue 40): imports run one way, cli -> report
-> estimate / frequency / design / discrepancy -> model / data -> _bridge ->
the base helpers; no import cycle between modules; and only mlid/_bridge.py
imports the extension mlid._core.  Read with ast from the installed
package's sources, imports inside functions included (a deferred import that
goes upward is still an upward import)."""

import ast
from pathlib import Path

import mlid
from mlid.design.signals import input_signal

#: Cross-cutting helpers at the top of the package, below everything else.
BASE = {"errors", "checks", "files", "heap", "openmp", "progress", "_version"}
#: The rank of each part of the package (a subpackage, a top-level module, or
#: "base" for BASE).  A module imports its own part and parts of lower rank
#: only; parts of equal rank (siblings) do not import each other.  core (an
#: old documented path, input_signal), mlid's __init__ (the public
#: names) and __main__ sit on top.
RANK = {
    "base": 0,
    "_bridge": 1,
    "data": 2,
    "model": 3,
    "estimate": 4,
    "frequency": 5,
    "design": 5,
    "online": 5,
    "export": 5,
    "discrepancy": 6,
    "report": 7,
    "cli": 8,
    "core": 9,
    "__init__": 10,
    "__main__": 10,
}
EXTENSION = "mlid._core"
BRIDGE = "mlid._bridge"


def modules(root):
    """{dotted name: path} of every .py file of the package at root."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def part(name):
    """The part of the package a module belongs to (RANK's keys)."""
    pieces = name.split(".")
    if len(pieces) == 1:
        return "__init__"
    return "base" if pieces[1] in BASE else pieces[1]


def imports(name, path, known):
    """(line, target module) of every import in the file, at any depth;
    'from X import a' names X.a when that is a module, else X."""
    is_package = path.name == "__init__.py"
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == "mlid"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                base = base[:len(base) - node.level + (1 if is_package else 0)]
                base = ".".join(base + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            if base.split(".")[0] != "mlid":
                continue
            for a in node.names:
                full = f"{base}.{a.name}"
                out.append((node.lineno, full if full in known or full == EXTENSION else base))
    return out


def graph(root):
    """{module: [(line, imported module of the package)]}: targets cut to the
    nearest module the package has (the extension kept as it is)."""
    known = modules(root)
    edges = {}
    for name, path in known.items():
        targets = []
        for line, target in imports(name, path, known):
            while target not in known and target != EXTENSION and "." in target:
                target = target.rsplit(".", 1)[0]
            if target != name:      # 'from . import x' where x is no module: the package
                targets.append((line, target))
        edges[name] = targets
    return edges


def core_importers(edges):
    """Modules other than the bridge that import the extension."""
    return sorted(f"{src}:{line}" for src, targets in edges.items() for line, dst in targets
                  if (dst == EXTENSION or dst.startswith(EXTENSION + ".")) and src != BRIDGE)


def cycles(edges):
    """The import cycles between modules: each strongly connected group of
    more than one module (Tarjan)."""
    succ = {src: sorted({d for _, d in targets if d in edges}) for src, targets in edges.items()}
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in succ[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(succ):
        if v not in index:
            visit(v)
    return found


def upward(edges, rank=RANK):
    """Imports of a part not below the importer's (and modules of no rank)."""
    bad = sorted(f"{name}: no rank for part {part(name)!r}" for name in edges
                 if part(name) not in rank)
    for src, targets in edges.items():
        for line, dst in targets:
            a, b = part(src), part(dst)
            if dst == EXTENSION or a == b or a not in rank or b not in rank:
                continue
            if rank[b] >= rank[a]:
                bad.append(f"{src}:{line} imports {dst} ({a} {rank[a]} -> {b} {rank[b]})")
    return bad


ROOT = Path(mlid.__file__).parent


def test_the_installed_package_is_read():
    edges = graph(ROOT)
    assert "mlid._bridge" in edges and "mlid.estimate.fit" in edges, sorted(edges)


def test_only_the_bridge_imports_the_extension():
    assert core_importers(graph(ROOT)) == []


def test_no_import_cycle():
    assert cycles(graph(ROOT)) == []


def test_imports_run_down_the_layers():
    assert upward(graph(ROOT)) == []


def test_paths_documented_before_the_layers_still_work():
    """mlid.core.input_signal and the modules mlid.campaign, compatibility,
    plots and reference, as the README had them, are the moved ones."""
    from mlid import plots
    from mlid.cli import campaign
    from mlid.design.signals import input_signal
    from mlid.estimate import compatibility
    from mlid.report import reference
    assert mlid.core.input_signal is input_signal
    assert (mlid.campaign, mlid.compatibility, mlid.reference) == (campaign, compatibility,
                                                                   reference)
    assert plots.__name__ == "mlid.report.plots" and mlid.plots is plots
    assert all(hasattr(mlid, name) for name in mlid.__all__)
