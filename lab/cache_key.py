"""Cache keys from content: the bytes of the code a result depends on, found from its imports.

A cached result (a spreadlet database, a reference render) is named by what produced it: its
settings and the source of every project module it imports, directly or through other modules,
including imports inside functions (most of splatlab imports lazily). The modules are found by
reading the import statements of the root modules' files, then of the files they import, and so
on (:func:`module_files`); nothing is listed by hand, and only ``lab`` and ``runtime_cl`` modules
count (third-party versions are the environment's business).

The key hashes file *contents* only, sorted, never paths or module names: moving a package
keeps its key, and code a result does not import (polygon rectification for a spreadlet
database, the executors that only schedule work) does not change it. A package's
``__init__.py`` counts only where it is imported itself (``from lab.optics import x`` reads
``lab/optics/__init__.py``; ``from lab.optics.iris import x`` does not).
"""
from __future__ import annotations

import ast
import hashlib
import importlib.util
from functools import lru_cache
from pathlib import Path

__all__ = ["PROJECT", "cached_code_digest", "code_digest", "module_files"]

PROJECT = ("lab", "runtime_cl")


def _project_dirs() -> dict[str, Path]:
    return {name: Path(importlib.util.find_spec(name).origin).parent for name in PROJECT}


def _locate(name: str, packages: dict[str, Path]) -> Path | None:
    """The file of module ``name`` if it belongs to one of ``packages`` (top-level name -> folder)."""
    top, *rest = name.split(".")
    base = packages.get(top)
    if base is None:
        return None
    path = base.joinpath(*rest)
    for candidate in (path.with_suffix(".py") if rest else None, path / "__init__.py"):
        if candidate is not None and candidate.is_file():
            return candidate
    return None


def _imports(path: Path, name: str, packages: dict[str, Path]) -> set[str]:
    """Project modules imported anywhere in the file of module ``name``."""
    tree = ast.parse(path.read_bytes(), filename=str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1])
                module = f"{base}.{node.module}" if node.module else base
            else:
                module = node.module
            # ``from pkg import sub`` imports the submodule ``pkg.sub`` when there is one
            subs = [f"{module}.{a.name}" for a in node.names if _locate(f"{module}.{a.name}", packages)]
            if len(subs) < len(node.names):
                found.add(module)
            found.update(subs)
    return {m for m in found if _locate(m, packages) is not None}


def _excluded(name: str, exclude) -> bool:
    return any(name == e or name.startswith(e + ".") for e in exclude)


def module_files(roots, packages: dict[str, Path] | None = None, exclude=()) -> dict[str, Path]:
    """Every project module that the ``roots`` import, transitively, with the roots themselves.

    Parameters
    ----------
    roots : iterable of str
        Dotted module names, e.g. ``["lab.precompute.cell"]``.
    packages : dict of str -> Path, optional
        Top-level package name -> its folder (default: where ``lab`` and ``runtime_cl`` are
        imported from). Tests point this at an edited copy of the tree.
    exclude : iterable of str, optional
        Modules and packages (dotted prefixes) left out, with what only they import: code the
        result imports but never runs (a test must show that it does not).

    Returns
    -------
    dict of str -> Path
        Module name -> source file.

    Raises
    ------
    ValueError
        A root is not a module of ``packages``.
    """
    packages = _project_dirs() if packages is None else {k: Path(v) for k, v in packages.items()}
    todo, seen = list(roots), {}
    for root in todo:
        if _locate(root, packages) is None:
            raise ValueError(f"cache key root {root!r}: no such module under {sorted(packages)}")
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        if _excluded(name, exclude):
            continue
        seen[name] = path = _locate(name, packages)
        todo.extend(_imports(path, name, packages) - seen.keys())
    return seen


def code_digest(roots, packages: dict[str, Path] | None = None, exclude=()) -> str:
    """sha256 (hex) of the sorted contents of :func:`module_files` ``(roots, packages, exclude)``."""
    files = module_files(roots, packages, exclude).values()
    h = hashlib.sha256()
    for digest in sorted(hashlib.sha256(f.read_bytes()).hexdigest() for f in files):
        h.update(digest.encode())
    return h.hexdigest()


@lru_cache(maxsize=32)
def cached_code_digest(roots: tuple) -> str:
    """:func:`code_digest` of the installed tree, once per process (workers check every task)."""
    return code_digest(roots)
