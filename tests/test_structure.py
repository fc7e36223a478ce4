"""The shape of the code, drawn from its imports (every import, lazy ones inside functions included).

- the core (`sdovon_mj`) never imports `exporters/` or `assets_convert/`: it reaches them through the
  plugin registry;
- no import circles between the core's units (a unit: a top-level module such as `sdovon_mj.records`, or a
  subpackage such as `sdovon_mj.nav`), nor between any two files of the project (the test fixtures of
  `tests/support/` included): a file that imports a file that imports it back can only be read with it;
- `nav` (agents) does not import `suite` (the environment and evaluation);
- stage packages never import the pipeline wiring (`stages`, `pipeline`, `commands`, `cli`);
- the product imports nothing of tests/, bench/ or tools/ (the fixtures of `tests/support/` are not part of it).
"""

from __future__ import annotations

import ast
import re
import functools
import io
import tokenize
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# (folder the package sits in, package): the product's packages, then the test fixtures (tests/support, `support`)
PRODUCT = ((ROOT, "sdovon_mj"), (ROOT, "exporters"), (ROOT, "assets_convert"))
PACKAGES = PRODUCT + ((ROOT / "tests", "support"),)
STAGE_PACKAGES = ("world", "sim", "observe", "perceive", "receptacles", "semantics", "place", "episodes", "nav", "suite")
WIRING = ("stages", "pipeline", "commands", "cli")


def _modules(packages: tuple[tuple[Path, str], ...] = PACKAGES) -> dict[str, Path]:
    """Return dotted module name -> file for every .py file of `packages` (a package is its __init__.py)."""
    mods = {}
    for base, pkg in packages:
        for p in (base / pkg).rglob("*.py"):
            parts = p.relative_to(base).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            mods[name] = p
    return mods


def _imports(mods: dict[str, Path]) -> dict[str, set[str]]:
    """Return module -> the project modules it imports (resolved, relative and lazy imports included).

    ``from pkg import name`` depends on the submodule ``pkg.name`` when there is one, else on ``pkg`` itself
    (its ``__init__``); ``import a.b`` on ``a.b``. The parent packages Python runs first are not counted:
    a package's ``__init__`` that imports its own submodules would otherwise close a circle with each of them.
    """
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
                cands = [f"{target}.{a.name}" if f"{target}.{a.name}" in mods else target for a in node.names]
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


def _top_level_imports(path: Path) -> set[str]:
    """Return the first component of every absolute import of a file (lazy ones included)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and not node.level and node.module:
            names.add(node.module.split(".")[0])
        elif isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
    return names


@functools.cache
def _project_graph() -> dict[str, set[str]]:
    """Return the file graph of the whole project (read once per test session)."""
    return _imports(_modules())


def _unit(mod: str) -> str:
    parts = mod.split(".")
    return ".".join(parts[:2]) if parts[0] == "sdovon_mj" and len(parts) > 1 else parts[0]


def _unit_graph() -> dict[str, set[str]]:
    g: dict[str, set[str]] = defaultdict(set)
    for a, bs in _project_graph().items():
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
    bad = sorted(f"{a} -> {b}" for a, bs in _project_graph().items() if a.startswith("sdovon_mj")
                 for b in bs if b.startswith(("exporters", "assets_convert")))
    assert not bad, bad


def test_no_import_circles():
    cycles = _cycles(_unit_graph())
    assert not cycles, cycles


def _circle_text(comp: list[str], g: dict[str, set[str]]) -> str:
    """Return one strongly connected set of files with the imports that tie it, for the failure message."""
    return "; ".join(f"{a} -> {', '.join(sorted(b for b in g[a] if b in comp))}" for a in comp)


def test_no_import_circles_between_files():
    """No two files of the project import each other, directly or through others (lazy imports count)."""
    g = _project_graph()
    cycles = _cycles(g)
    assert not cycles, "import circles between files:\n" + "\n".join(_circle_text(c, g) for c in cycles)


def test_the_cycle_finder_finds_circles():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_the_file_graph_sees_lazy_relative_and_package_imports(tmp_path):
    """The file graph finds a circle closed by a lazy `from . import b` and one through a package's `__init__`
    (`from .. import VALUE`); `from . import b` is an import of b, not of the package, so `pkg` importing
    `pkg.a` closes no circle with it."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from .a import f\nfrom .sub import g\n")
    (pkg / "a.py").write_text("def f():\n    from . import b\n    return b\n")
    (pkg / "b.py").write_text("from pkg.a import f\n")
    (pkg / "sub" / "__init__.py").write_text("from .c import g\n")
    (pkg / "sub" / "c.py").write_text("def g():\n    from .. import VALUE\n")
    g = _imports(_modules(((tmp_path, "pkg"),)))
    assert g["pkg.a"] == {"pkg.b"} and g["pkg.sub.c"] == {"pkg"}
    assert sorted(_cycles(g)) == [["pkg", "pkg.sub", "pkg.sub.c"], ["pkg.a", "pkg.b"]]


def test_stage_packages_do_not_reach_the_wiring_and_nav_not_the_suite():
    g = _unit_graph()
    for pkg in STAGE_PACKAGES:
        wrong = sorted(u for u in g.get(f"sdovon_mj.{pkg}", ()) if u.split(".")[-1] in WIRING)
        assert not wrong, (pkg, wrong)
    assert "sdovon_mj.suite" not in g.get("sdovon_mj.nav", set())


def test_the_product_imports_nothing_of_tests_bench_or_tools():
    """Fixtures live in tests/support (not installed); no product file imports them or any test, bench or tool."""
    assert not (ROOT / "sdovon_mj" / "testing").exists()
    outside = {p.stem if p.suffix == ".py" else p.name for d in ("tests", "bench", "tools") for p in (ROOT / d).iterdir()
               if p.suffix == ".py" or (p / "__init__.py").exists()} | {"tests", "bench", "tools"}
    assert "support" in outside
    users = sorted(f"{name} -> {sorted(hit)}" for name, path in _modules(PRODUCT).items()
                   if (hit := _top_level_imports(path) & outside))
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


def test_every_name_the_scripts_import_from_the_product_exists():
    """Every ``from sdovon_mj... import name`` in bench/, tools/, examples/ and tests/ (at the top or inside a function,
    where only running that code path would find it) names something the module has."""
    import ast
    import importlib

    missing = []
    for d in ("bench", "tools", "examples", "tests"):
        for path in sorted((ROOT / d).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("sdovon_mj"):
                    try:
                        module = importlib.import_module(node.module)
                    except ModuleNotFoundError:
                        missing.append(f"{path.relative_to(ROOT)}:{node.lineno}: no module {node.module}")
                        continue
                    missing += [f"{path.relative_to(ROOT)}:{node.lineno}: {node.module}.{a.name}" for a in node.names
                                if a.name != "*" and not hasattr(module, a.name)
                                and importlib.util.find_spec(f"{node.module}.{a.name}") is None]
    assert not missing, missing


# ----------------------------------------------------------------------------------------------
# The run folder's layout has one home: `sdovon_mj.runview` (RunLayout, RunView)

# Folders of a run that a module spells when it joins them with `/` (``root / "scenes"``).
RUN_DIRS = {"scenes", "variants", "observe", "perceive", "semantics", "objects", "stats", "export", "inputs"}
# A run-folder path written as text: a run folder's top-level folder followed by more of the path
# (``scenes/{scene}``, ``objects/objects.json``, ``export/{fmt}``), or one of the run's record files by name.
RUN_PATH = re.compile(r"(^|/)(scenes|variants|objects|inputs|export|stats)/"
                      r"|(^|/)(scene|variant|episodes|objects|object|planes|relevance|manifest|timings|inputs|failures"
                      r"|llm|targeted_views)\.json$|(^|/)instances\.npz$|(^|/)variant\.xml$|(^|/)config\.yaml$"
                      r"|(^|/)(navmap|regions)_(\*|\d|$)")
LAYOUT_HOME = "sdovon_mj/runview.py"
# Spellings that are not run-folder paths, each with why: other layouts that share a name with a run's (the MJCF
# bundle's, the exporters' outputs, the world writers' inputs), data outside the project. (file, text) pairs, so a
# new run-folder path in one of these files still fails.
NOT_RUN_PATHS = {
    ("sdovon_mj/world/io/habitat.py", "scenes"): "the Habitat scene dataset the world writer makes",
    ("sdovon_mj/world/io/habitat.py", "objects"): "the Habitat scene dataset the world writer makes",
    ("sdovon_mj/world/io/habitat.py", "objects/"): "the Habitat scene dataset the world writer makes",
    ("sdovon_mj/world/io/habitat.py", "semantics"): "the Habitat scene dataset the world writer makes",
    ("sdovon_mj/commands/world.py", "objects"): "`sdovon-mj world`'s output folder (input files, not a run)",
    ("sdovon_mj/commands/semantics_eval.py", "semantics"): "the shared judgement data (../shared/semantics)",
    ("sdovon_mj/suite/bundle.py", "episodes.json"): "the MJCF bundle's layout",
    ("sdovon_mj/suite/bundle.py", "variant.xml"): "the MJCF bundle's layout",
    ("sdovon_mj/suite/bundle.py", "relevance.json"): "the MJCF bundle's layout",
    ("sdovon_mj/suite/__init__.py", "episodes.json"): "the MJCF bundle's layout",
    ("exporters/mjcf_bundle/__init__.py", "episodes.json"): "the MJCF bundle's layout",
    ("exporters/mjcf_bundle/__init__.py", "relevance.json"): "the MJCF bundle's layout",
    ("exporters/mjcf_bundle/__init__.py", "navmap_"): "the MJCF bundle's layout",
    ("exporters/urdf/__init__.py", "scene.json"): "the URDF export's layout",
    ("exporters/urdf/__init__.py", "episodes.json"): "the URDF export's layout",
    ("exporters/usd/__init__.py", "scenes"): "the USD export's layout",
    ("exporters/usd/__init__.py", "objects"): "the USD export's layout",
    ("exporters/usd/__init__.py", "variants"): "the USD export's layout",
    ("exporters/usd/__init__.py", "variants/"): "the USD export's layout",
    ("exporters/habitat/__init__.py", "scenes"): "the Habitat dataset export's layout",
    ("exporters/habitat/__init__.py", "/scenes/"): "the Habitat dataset export's layout",
    ("exporters/habitat/__init__.py", "objects"): "the Habitat dataset export's layout",
    ("exporters/habitat/__init__.py", "objects/"): "the Habitat dataset export's layout",
}


def _docstring_nodes(tree: ast.AST) -> set[int]:
    """Return the ids of the docstring constants of a parsed module (module, class and function docstrings)."""
    out = set()
    for n in ast.walk(tree):
        if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and n.body:
            first = n.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def run_folder_paths(source: str) -> list[tuple[int, str]]:
    """Return (line, text) of each run-folder path a module's code spells: a string (or an f-string's literal part)
    that `RUN_PATH` matches, or one of `RUN_DIRS` joined with ``/``. Docstrings and prose (text with spaces) are
    not paths."""
    tree = ast.parse(source)
    docs = _docstring_nodes(tree)
    joined = {id(side) for n in ast.walk(tree) if isinstance(n, ast.BinOp) and isinstance(n.op, ast.Div)
              for side in (n.left, n.right)}
    hits = []
    for n in ast.walk(tree):
        if not (isinstance(n, ast.Constant) and isinstance(n.value, str)) or id(n) in docs or " " in n.value.strip():
            continue
        if RUN_PATH.search(n.value) or (n.value in RUN_DIRS and id(n) in joined):
            hits.append((n.lineno, n.value))
    return sorted(hits)


def test_run_folder_paths_are_composed_in_the_run_layout_only():
    """Every path inside a run folder is composed by `sdovon_mj.runview` (RunLayout, RunView): no other module of the
    product spells one (stages, statistics, audit, commands, exporters ask it)."""
    bad = []
    for base in ("sdovon_mj", "exporters"):
        for path in sorted((ROOT / base).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel == LAYOUT_HOME:
                continue
            for line, text in run_folder_paths(path.read_text(encoding="utf-8")):
                if (rel, text) not in NOT_RUN_PATHS:
                    bad.append(f"{rel}:{line}: {text!r}")
    assert not bad, "run-folder paths composed outside sdovon_mj/runview.py (use RunLayout / RunView):\n" + "\n".join(bad)


def test_the_run_path_finder_finds_paths():
    """The finder sees the ways a run-folder path gets spelt, and not prose, docstrings or other names."""
    src = '''"""A docstring naming scenes/<scene>/scene.json."""
a = root / "scenes" / name / "scene.json"
b = f"scenes/{scene}/variants/{v}/variant.json"
c = store.path(f"{d}/planes.json")
d = sorted(p.glob("navmap_*.json"))
e = "a sentence about scenes/ and config.yaml"
f = navmap_image(x)
g = "navmap_image"
h = root / "config.yaml"
'''
    assert run_folder_paths(src) == [(2, "scene.json"), (2, "scenes"), (3, "/variant.json"), (3, "/variants/"),
                                     (3, "scenes/"), (4, "/planes.json"), (5, "navmap_*.json"), (9, "config.yaml")]


# ----------------------------------------------------------------------------------------------
# Nothing dangling: every repository path the code's docstrings and comments name exists

# Top-level folders of the repository (and the one it must never cite: research/ is outside the product).
REPO_TOPS = ("research", "docs", "tests", "sdovon_mj", "assets_convert", "exporters", "tools", "bench", "mjcf_templates")
REFERENCE_SCOPE = ("sdovon_mj", "assets_convert", "exporters", "mjcf_templates", "tools", "bench")
# Text that looks like a repository path and is not one, each with why.
NOT_REFERENCES = {"sdovon_mj/ObjectNav-v0": "the Gymnasium environment id"}


def _reference_pattern() -> re.Pattern[str]:
    """Return the pattern of a repository path in prose: a top-level folder and more (``docs/evaluation.md``,
    ``tests/support``), or a module path inside the package (``world/articulated.py``). A path inside another
    project's (``habitat-lab/habitat/tasks/nav/nav.py``) is not one: the match may not follow a name, dot or slash."""
    subs = sorted(p.name for p in (ROOT / "sdovon_mj").iterdir() if (p / "__init__.py").exists())
    return re.compile(r"(?<![\w./-])((?:%s)/[\w./-]*[\w/]|(?:%s)/[\w/-]*\.py)\b" % ("|".join(REPO_TOPS), "|".join(subs)))


def _prose(source: str) -> list[tuple[int, str]]:
    """Return (line, text) of a module's docstrings and comments."""
    out = []
    tree = ast.parse(source)
    for n in ast.walk(tree):
        if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(n, clean=False)
            if doc:
                out.append((n.body[0].lineno, doc))
    out += [(t.start[0], t.string) for t in tokenize.generate_tokens(io.StringIO(source).readline)
            if t.type == tokenize.COMMENT]
    return out


def dangling_references(source: str, pattern: re.Pattern[str] | None = None) -> list[tuple[int, str]]:
    """Return (line, path) of each repository path a module's docstrings and comments name that does not exist (a
    module path such as ``world/home.py`` is looked up inside ``sdovon_mj/``)."""
    pattern = pattern or _reference_pattern()
    out = []
    for line, text in _prose(source):
        for m in pattern.finditer(text):
            ref = m.group(1).rstrip("/.")
            if ref in NOT_REFERENCES:
                continue
            base = ROOT if ref.split("/")[0] in REPO_TOPS else ROOT / "sdovon_mj"
            if not (base / ref).exists():
                out.append((line, ref))
    return out


def test_no_dangling_repository_references():
    """Every repository path named in the product's docstrings and comments (and the tools' and benches') exists;
    research notes are outside the repository (their facts are in docs/background.md)."""
    pattern = _reference_pattern()
    bad = [f"{p.relative_to(ROOT).as_posix()}:{line}: {ref}" for d in REFERENCE_SCOPE for p in sorted((ROOT / d).rglob("*.py"))
           for line, ref in dangling_references(p.read_text(encoding="utf-8"), pattern)]
    assert not bad, "references to files this repository does not have:\n" + "\n".join(bad)


def test_the_reference_check_finds_dangling_paths():
    src = '''"""Facts in research/peers.md section 0 and docs/evaluation.md; wired in world/apartment.py, see world/home.py.

The habitat-lab file ``habitat-lab/habitat/tasks/nav/nav.py`` is another project's.
"""
# tests/no_such_test.py and tests/test_structure.py; the id sdovon_mj/ObjectNav-v0
x = "docs/nowhere.md"  # a string, not prose: the run-path and config checks see those
'''
    assert dangling_references(src) == [(1, "research/peers.md"), (1, "world/apartment.py"), (5, "tests/no_such_test.py")]
