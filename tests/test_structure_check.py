"""scripts/check_structure.py (issue 27): functions over 100 lines and files over 600 lines
without a "Why one file:" reason fail `make lint`, named with their length; a clean tree passes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "check_structure.py"


def _function(name: str, body_lines: int, indent: str = "") -> str:
    """A function of exactly 1 + body_lines lines (the def and its body)."""
    body = "".join(f"{indent}    x{i} = {i}\n" for i in range(body_lines - 1))
    return f"{indent}def {name}():\n{body}{indent}    return 0\n"


def _run(*roots: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, roots)], capture_output=True, text=True, timeout=60)


def test_clean_tree_passes(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    # exactly at both limits: a 100-line function, a 600-line file
    text = '"""A module."""\n' + _function("at_limit", 99)
    text += "".join(f"y{i} = {i}\n" for i in range(600 - len(text.splitlines())))
    assert len(text.splitlines()) == 600
    (pkg / "ok.py").write_text(text)
    # a long file with its reason
    reason = '"""A long table.\n\nWhy one file: one table of constants read as a whole.\n"""\n'
    (pkg / "long_ok.py").write_text(reason + "".join(f"z{i} = {i}\n" for i in range(700)))
    done = _run(pkg)
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout == ""


def test_long_function_and_long_file_fail_with_names(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "funcs.py").write_text(
        '"""Functions."""\n'
        + _function("short", 10)
        + "class Planner:\n"
        + _function("plan", 101, indent="    ")
        + "async "
        + _function("fetch", 130)
    )
    # 601 lines, a docstring without the reason, and one whose "Why one file:" has no reason
    (pkg / "sub" / "big.py").write_text('"""Big."""\n' + "".join(f"a{i} = {i}\n" for i in range(600)))
    (pkg / "sub" / "empty_reason.py").write_text(
        '"""Big.\n\nWhy one file:\n"""\n' + "".join(f"b{i} = {i}\n" for i in range(700))
    )
    done = _run(pkg)
    assert done.returncode == 1
    lines = done.stdout.splitlines()
    assert len(lines) == 4, done.stdout
    assert any(ln.endswith("funcs.py:14 Planner.plan 102 lines > 100 (function)") for ln in lines), lines
    assert any("funcs.py:" in ln and " fetch 131 lines > 100" in ln for ln in lines), lines
    assert any("big.py:1 <file> 601 lines > 600" in ln for ln in lines), lines
    assert any("empty_reason.py:1 <file> 704 lines > 600" in ln for ln in lines), lines
    assert "short" not in done.stdout
    assert "4 fault(s)" in done.stderr


def test_nested_function_counted_in_its_own_right(tmp_path: Path) -> None:
    inner = _function("inner", 105, indent="    ")
    (tmp_path / "m.py").write_text("def outer():\n" + inner + "    return inner\n")
    done = _run(tmp_path / "m.py")
    assert done.returncode == 1
    names = [ln.split()[1] for ln in done.stdout.splitlines()]
    assert names == ["outer", "outer.inner"]


def test_missing_root_and_syntax_error_exit_2(tmp_path: Path) -> None:
    done = _run(tmp_path / "nope")
    assert done.returncode == 2
    assert "nope: no such file or folder" in done.stderr
    (tmp_path / "bad.py").write_text("def f(:\n")
    done = _run(tmp_path)
    assert done.returncode == 2
    assert "bad.py:1: does not parse" in done.stderr
    assert "Traceback" not in done.stderr
