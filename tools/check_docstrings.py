"""List public functions with more than four parameters whose docstring has no numpydoc "Parameters" section
naming each parameter (maintainer check, ast-based: nothing is imported).

    python tools/check_docstrings.py [PATH ...]

PATH is a .py file or a folder (searched recursively); with none, every package of the product
(``DEFAULT_PATHS``). Counted: module-level functions and methods of classes whose names
do not start with ``_`` (``__init__`` included, documented in its own or its class's docstring);
``self`` and ``cls`` are not parameters, ``*args``/``**kwargs`` are. A parameter is named by an entry
line ``name : type`` (or ``a, b : type``) in the section that starts with ``Parameters`` over a dashed
line.

A function that forwards to another of the same module may document its parameters by reference
instead (the numpydoc way of trimesh): the sentence ``Parameters are those of `other`.`` in its
docstring stands for a Parameters section, and an entry ``a, b : as in `other``` documents ``a`` and
``b``. ``other`` is a module-level function or ``Class.method`` of the same file (a bare method name
also finds a method of the referring function's own class); a reference counts only when ``other``
documents, itself or by its own references, every parameter it is taken to document.

Prints ``path:line: name: ...`` per finding and exits 1 when there is one.
"""

from __future__ import annotations

import argparse
import ast
import re
import sys
from pathlib import Path
from typing import Iterator

ROOT = Path(__file__).resolve().parent.parent
MAX_UNDOCUMENTED = 4  # more parameters than this need a Parameters section
DEFAULT_PATHS = ("sdovon_mj", "assets_convert", "exporters", "mjcf_templates")  # every package of the product
_SECTION = re.compile(r"^\s*-{3,}\s*$")
_REF = r"`([A-Za-z_][\w.]*)`"
_WHOLE_REF = re.compile(r"\bParameters\s+are\s+those\s+of\s+" + _REF)  # the sentence standing for a section
_ENTRY_REF = re.compile(r"^as in " + _REF + r"\.?$")  # the type part of an entry: "a, b : as in `f`"


def parameter_names(fn: ast.FunctionDef | ast.AsyncFunctionDef, method: bool) -> list[str]:
    """Return a function's parameter names in order (``self``/``cls`` of a method left out)."""
    a = fn.args
    names = [x.arg for x in (*a.posonlyargs, *a.args)]
    if method and names and names[0] in ("self", "cls"):
        names = names[1:]
    if a.vararg is not None:
        names.append(a.vararg.arg)
    names += [x.arg for x in a.kwonlyargs]
    if a.kwarg is not None:
        names.append(a.kwarg.arg)
    return names


def documented_parameters(doc: str | None) -> set[str]:
    """Return the names listed in a docstring's numpydoc ``Parameters`` section (empty if it has none)."""
    own, _refs = parameter_entries(doc)
    return own


def parameter_entries(doc: str | None) -> tuple[set[str], list[tuple[list[str], str]]]:
    """Return a docstring's own parameter names and its references: (names, referenced function) pairs.

    Own names are the entries of its ``Parameters`` section; a reference is an entry ``a, b : as in `f```
    (names ``a``, ``b``) or the sentence ``Parameters are those of `f`.`` (names: an empty list, standing
    for every parameter).
    """
    lines = (doc or "").expandtabs().splitlines()
    names: set[str] = set()
    refs: list[tuple[list[str], str]] = [([], m.group(1)) for m in _WHOLE_REF.finditer(" ".join(lines))]
    inside, indent = False, 0
    for k, line in enumerate(lines):
        nxt = lines[k + 1] if k + 1 < len(lines) else ""
        if line.strip() and _SECTION.match(nxt):  # a section header
            inside = line.strip() == "Parameters"
            indent = len(line) - len(line.lstrip())
            continue
        if not inside or not line.strip() or _SECTION.match(line):
            continue
        if len(line) - len(line.lstrip()) == indent:  # an entry line: "name : type" or "a, b : type"
            head, _sep, kind = line.partition(" : ")
            entry = [n.strip().lstrip("*") for n in head.split(",")]
            ref = _ENTRY_REF.match(kind.strip())
            if ref:
                refs.append((entry, ref.group(1)))
            else:
                names.update(entry)
    return names, refs


class _Module:
    """The functions of one parsed file, to resolve references between their docstrings."""

    def __init__(self, tree: ast.Module) -> None:
        self.functions: dict[str, tuple[ast.FunctionDef | ast.AsyncFunctionDef, ast.ClassDef | None]] = {}
        for node in tree.body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                self.functions[node.name] = (node, None)
            elif isinstance(node, ast.ClassDef):
                for item in node.body:
                    if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                        self.functions[f"{node.name}.{item.name}"] = (item, node)

    def find(self, name: str, cls: ast.ClassDef | None) -> tuple[ast.FunctionDef | ast.AsyncFunctionDef,
                                                                 ast.ClassDef | None] | None:
        """Return the function a reference names (a method of `cls` first for a bare name), or None."""
        if cls is not None and "." not in name and f"{cls.name}.{name}" in self.functions:
            return self.functions[f"{cls.name}.{name}"]
        return self.functions.get(name)

    def documented(self, fn: ast.FunctionDef | ast.AsyncFunctionDef, cls: ast.ClassDef | None,
                   seen: frozenset[int] = frozenset()) -> set[str]:
        """Return the parameters of `fn` that its docstring documents, itself or by valid references."""
        names = _parameter_names(fn, cls)
        own, refs = parameter_entries(ast.get_docstring(fn))
        if fn.name == "__init__" and cls is not None:
            more, more_refs = parameter_entries(ast.get_docstring(cls))
            own, refs = own | more, refs + more_refs
        documented = own & set(names)
        for entry, target in refs:
            found = self.find(target, cls)
            if found is None or id(found[0]) in seen or found[0] is fn:
                continue
            theirs = self.documented(*found, seen=seen | {id(fn)})
            wanted = set(entry) if entry else set(names)
            if wanted <= theirs:  # the referenced function documents every parameter taken from it
                documented |= wanted & set(names)
        return documented


def _parameter_names(fn: ast.FunctionDef | ast.AsyncFunctionDef, cls: ast.ClassDef | None) -> list[str]:
    """Return the parameter names of a function or method (a static method keeps its first one)."""
    return parameter_names(fn, cls is not None and not any(
        isinstance(d, ast.Name) and d.id == "staticmethod" for d in fn.decorator_list))


def _functions(tree: ast.Module) -> Iterator[tuple[ast.FunctionDef | ast.AsyncFunctionDef, ast.ClassDef | None]]:
    """Yield the public module-level functions and public methods of public classes (with their class)."""
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not node.name.startswith("_"):
            yield node, None
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            for item in node.body:
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)) and (
                        not item.name.startswith("_") or item.name == "__init__"):
                    yield item, node


def check_file(path: Path) -> list[str]:
    """Return one finding per public function of a file with too many undocumented parameters."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    try:
        shown = path.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        shown = str(path)
    out = []
    module = _Module(tree)
    for fn, cls in _functions(tree):
        names = _parameter_names(fn, cls)
        if len(names) <= MAX_UNDOCUMENTED:
            continue
        documented = module.documented(fn, cls)
        missing = [n for n in names if n not in documented]
        if missing:
            name = f"{cls.name}.{fn.name}" if cls is not None else fn.name
            refs = [t for _e, t in parameter_entries(ast.get_docstring(fn))[1]]
            what = "no Parameters section" if not documented and not refs else "Parameters section lacks " + ", ".join(missing)
            if refs:
                what += " (not documented by " + ", ".join(f"`{t}`" for t in dict.fromkeys(refs)) + " of this file)"
            out.append(f"{shown}:{fn.lineno}: {name} ({len(names)} parameters): {what}")
    return out


def default_files() -> list[Path]:
    """Return the checked files of the tree: every .py file under ``DEFAULT_PATHS``."""
    return _expand([ROOT / p for p in DEFAULT_PATHS])


def _expand(paths: list[Path]) -> list[Path]:
    """Return the .py files of files and folders (folders searched recursively), sorted."""
    files: set[Path] = set()
    for p in paths:
        files.update(sorted(p.rglob("*.py")) if p.is_dir() else [p])
    return sorted(files)


def main(argv: list[str] | None = None) -> int:
    """Run the check; return the exit status (1 when a function lacks parameter docs)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="*", type=Path, help="files or folders (default: every package of the product)")
    args = ap.parse_args(argv)
    files = _expand(args.paths) if args.paths else default_files()
    findings = [f for p in files for f in check_file(p)]
    for f in findings:
        print(f)
    print(f"{len(files)} files, {len(findings)} functions without parameter docs", file=sys.stderr)
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
