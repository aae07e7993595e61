"""Functions longer than a limit (default 80 lines) in the product's packages, found by ``ast``.

Why: issue 31 asks for small functions whose names tell the steps; this lists the ones that are
not, longest first, so a change can report the count before -> after.

    python scripts/long_functions.py [--limit 80] [DIR ...]   (default: calib logtools viz)
"""

from __future__ import annotations

import argparse
import ast
from collections.abc import Iterator, Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("calib", "logtools", "viz")

__all__ = ["long_functions", "main"]


def _functions(tree: ast.AST, prefix: str = "") -> Iterator[tuple[str, int, int]]:
    """(qualified name, first line, line count) of every function in ``tree``, nested included;
    the count runs from the ``def`` (decorators excluded) to the last line of the body."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            name = f"{prefix}{node.name}"
            end = node.end_lineno or node.lineno
            yield name, node.lineno, end - node.lineno + 1
            yield from _functions(node, f"{name}.")
        elif isinstance(node, ast.ClassDef):
            yield from _functions(node, f"{prefix}{node.name}.")
        else:
            yield from _functions(node, prefix)


def long_functions(dirs: Sequence[Path], limit: int) -> list[tuple[int, str, str, int]]:
    """(lines, file, qualified name, first line) of every function over ``limit`` lines under
    ``dirs``, longest first."""
    out: list[tuple[int, str, str, int]] = []
    for d in dirs:
        for path in [d] if d.is_file() else sorted(d.rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            rel = str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)
            out += [(n, rel, name, line) for name, line, n in _functions(tree) if n > limit]
    return sorted(out, key=lambda r: (-r[0], r[1], r[3]))


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dirs", nargs="*", type=Path)
    ap.add_argument("--limit", type=int, default=80)
    a = ap.parse_args(argv)
    dirs = [d.resolve() for d in a.dirs] or [ROOT / p for p in PACKAGES]
    rows = long_functions(dirs, a.limit)
    for n, rel, name, line in rows:
        print(f"{n:5d}  {rel}:{line}  {name}")
    print(f"{len(rows)} functions over {a.limit} lines")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
