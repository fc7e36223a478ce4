"""The shape of the code, drawn from its imports (every import, lazy ones inside functions included).

- the core (`sdovon_mj`) never imports `exporters/` or `assets_convert/`: it reaches them through the
  plugin registry;
- no import circles between the core's units (a unit: a top-level module such as `sdovon_mj.records`, or a
  subpackage such as `sdovon_mj.nav`);
- `nav` (agents) does not import `suite` (the environment and evaluation);
- stage packages never import the pipeline wiring (`stages`, `pipeline`, `commands`, `cli`);
- nothing outside tests/bench imports `sdovon_mj.testing` (fixtures are not part of the pipeline).
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sdovon_mj", "exporters", "assets_convert")
STAGE_PACKAGES = ("world", "sim", "observe", "perceive", "receptacles", "semantics", "place", "episodes", "nav", "suite")
WIRING = ("stages", "pipeline", "commands", "cli")


def _modules() -> dict[str, Path]:
    mods = {}
    for pkg in PACKAGES:
        for p in (ROOT / pkg).rglob("*.py"):
            parts = p.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            mods[name] = p
    return mods


def _imports(mods: dict[str, Path]) -> dict[str, set[str]]:
    """Return module -> the project modules it imports (resolved, relative imports included)."""
    out: dict[str, set[str]] = defaultdict(set)
    for name, path in mods.items():
        pkg = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                cands = [target] + [f"{target}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                cands = [a.name for a in node.names]
            else:
                continue
            for c in cands:
                while c and c not in mods:
                    c = c.rpartition(".")[0]
                if c and c != name:
                    out[name].add(c)
    return out


def _unit(mod: str) -> str:
    parts = mod.split(".")
    return ".".join(parts[:2]) if parts[0] == "sdovon_mj" and len(parts) > 1 else parts[0]


def _unit_graph() -> dict[str, set[str]]:
    g: dict[str, set[str]] = defaultdict(set)
    for a, bs in _imports(_modules()).items():
        for b in bs:
            if _unit(a) != _unit(b):
                g[_unit(a)].add(_unit(b))
    return g


def _cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """Return the strongly connected components with more than one unit (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(g.get(v, ())):
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

    for v in sorted(set(g) | {w for ws in g.values() for w in ws}):
        if v not in index:
            visit(v)
    return out


def test_the_core_never_imports_exporters_or_converters():
    bad = sorted(f"{a} -> {b}" for a, bs in _imports(_modules()).items() if a.startswith("sdovon_mj")
                 for b in bs if b.startswith(("exporters", "assets_convert")))
    assert not bad, bad


def test_no_import_circles():
    cycles = _cycles(_unit_graph())
    assert not cycles, cycles


def test_the_cycle_finder_finds_circles():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_stage_packages_do_not_reach_the_wiring_and_nav_not_the_suite():
    g = _unit_graph()
    for pkg in STAGE_PACKAGES:
        wrong = sorted(u for u in g.get(f"sdovon_mj.{pkg}", ()) if u.split(".")[-1] in WIRING)
        assert not wrong, (pkg, wrong)
    assert "sdovon_mj.suite" not in g.get("sdovon_mj.nav", set())


def test_fixtures_stay_out_of_the_pipeline():
    users = sorted(a for a, bs in _imports(_modules()).items()
                   if not a.startswith("sdovon_mj.testing") and any(b.startswith("sdovon_mj.testing") for b in bs))
    assert not users, users


def _module_graph(prefix: str) -> dict[str, set[str]]:
    """Return module -> modules it imports among `prefix`'s modules, a ``from pkg import submodule`` counted as an
    import of that submodule only (not of the package's ``__init__``), lazy imports included."""
    import ast as _ast

    mods = _modules()
    g: dict[str, set[str]] = defaultdict(set)
    for name, path in mods.items():
        if not name.startswith(prefix):
            continue
        pkg = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in _ast.walk(_ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, _ast.ImportFrom):
                base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)] if node.level else []
                target = ".".join(base + ([node.module] if node.module else [])) if node.level else (node.module or "")
                cands = [f"{target}.{a.name}" if f"{target}.{a.name}" in mods else target for a in node.names]
            elif isinstance(node, _ast.Import):
                cands = [a.name for a in node.names]
            else:
                continue
            for c in cands:
                while c and c not in mods:
                    c = c.rpartition(".")[0]
                if c and c != name and c.startswith(prefix):
                    g[name].add(c)
    return g


def test_no_module_circles_in_the_converter():
    """No two files of assets_convert import each other, directly or round a longer circle (lazy imports count)."""
    assert _cycles(_module_graph("assets_convert")) == []
