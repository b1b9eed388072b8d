"""Structure rules of issue 27 on the backend, checked by `make lint`.

    .venv/bin/python scripts/check_structure.py [ROOT ...]    # default: backend/waamflow

- no function (or method) over 100 lines, counted from its `def` line to its last line
  (decorators not counted), read with `ast`;
- no file over 600 lines unless its module docstring has a paragraph starting "Why one file:"
  that gives the reason (a non-empty sentence after the colon).

There is no allow-list: split the function or the file, or give the file its reason.
Exit 0 when clean; 1 with one line per fault (path:line name length limit); 2 on a bad
argument (a root that does not exist, or a file that does not parse).
"""

from __future__ import annotations

import ast
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_ROOTS = (ROOT / "backend" / "waamflow",)
MAX_FUNCTION_LINES = 100
MAX_FILE_LINES = 600
REASON_PREFIX = "Why one file:"


@dataclass(frozen=True)
class Fault:
    path: Path
    line: int
    name: str
    length: int
    limit: int
    what: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line} {self.name} {self.length} lines > {self.limit} ({self.what})"


def _has_reason(tree: ast.Module) -> bool:
    doc = ast.get_docstring(tree, clean=True)
    if not doc:
        return False
    for paragraph in doc.split("\n\n"):
        text = paragraph.strip()
        if text.startswith(REASON_PREFIX) and text[len(REASON_PREFIX) :].strip():
            return True
    return False


def _qualified_functions(tree: ast.Module) -> list[tuple[str, ast.FunctionDef | ast.AsyncFunctionDef]]:
    """Every function and method with its dotted name (Class.method, outer.inner)."""
    found: list[tuple[str, ast.FunctionDef | ast.AsyncFunctionDef]] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                found.append((name, child))
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            else:
                visit(child, prefix)

    visit(tree, "")
    return found


def check_file(path: Path, shown: Path | None = None) -> list[Fault]:
    """The faults of one Python file (`shown` is the path printed; default `path`)."""
    shown = shown or path
    source = path.read_text(encoding="utf-8")
    tree = ast.parse(source, filename=str(path))
    faults: list[Fault] = []
    n_lines = len(source.splitlines())
    if n_lines > MAX_FILE_LINES and not _has_reason(tree):
        faults.append(
            Fault(
                shown, 1, "<file>", n_lines, MAX_FILE_LINES, f'no "{REASON_PREFIX}" paragraph in the module docstring'
            )
        )
    for name, fn in _qualified_functions(tree):
        end = fn.end_lineno or fn.lineno
        length = end - fn.lineno + 1
        if length > MAX_FUNCTION_LINES:
            faults.append(Fault(shown, fn.lineno, name, length, MAX_FUNCTION_LINES, "function"))
    return faults


def _shown(path: Path) -> Path:
    """The path as printed: relative to the repository when inside it."""
    try:
        return path.relative_to(ROOT)
    except ValueError:
        return path


def check_tree(root: Path) -> list[Fault]:
    """The faults of every .py file under `root` (a file or a folder), in path order."""
    files = [root] if root.is_file() else sorted(root.rglob("*.py"))
    faults: list[Fault] = []
    for path in files:
        faults.extend(check_file(path, _shown(path)))
    return faults


def main(argv: list[str]) -> int:
    roots = [Path(a).resolve() for a in argv] or list(DEFAULT_ROOTS)
    faults: list[Fault] = []
    for root in roots:
        if not root.exists():
            print(f"check_structure: {root}: no such file or folder", file=sys.stderr)
            return 2
        try:
            faults.extend(check_tree(root))
        except SyntaxError as exc:
            print(f"check_structure: {exc.filename}:{exc.lineno}: does not parse: {exc.msg}", file=sys.stderr)
            return 2
    for fault in faults:
        print(fault)
    if faults:
        print(
            f"check_structure: {len(faults)} fault(s): functions over {MAX_FUNCTION_LINES} lines, "
            f'files over {MAX_FILE_LINES} lines without "{REASON_PREFIX}" (issue 27)',
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
