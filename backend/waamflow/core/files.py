"""The one gate every file a node reads goes through (#26 faults 2-4).

A file is opened once, without following a final symlink and without blocking (a FIFO's open would
wait for a writer), and what was opened is checked on its descriptor: a regular file (no FIFO,
device, socket, folder), not larger than the limit before a byte is read, and read to at most the
limit (a file that grows meanwhile is cut off, not swallowed). Shipped data (robot profiles and
descriptions, cells, machine profiles) is named, never pathed: a name is letters, digits, `_ - .`
without `..` or a separator, looked up in its folder. Errors name the parameter's value and what
is wrong with it; they never quote the file's content, and a refused name never touches the disk,
so they cannot tell whether a file outside the allowed folders exists.
"""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator, Field

from .errors import InputFileError

# a shipped name: no separator, no '..', no leading dot (also the JSON Schema `pattern` of the
# params that take one; no look-ahead, so JSON Schema and pydantic's engine read it alike)
SHIPPED_NAME_PATTERN = r"^(?:[A-Za-z0-9][A-Za-z0-9_-]*(?:\.[A-Za-z0-9_-]+)*)?$"
SHIPPED_NAME = re.compile(SHIPPED_NAME_PATTERN)


def _shipped_name(v: str) -> str:
    if v and not SHIPPED_NAME.match(v):
        raise ValueError("a shipped name (letters, digits, _ - . without '/' or '..'): a path is never read here")
    return v


def shipped(folder: str, **field: Any) -> Any:
    """A params field that names shipped data in `data/<folder>`: the pattern in its JSON Schema
    (and `x-shipped`, so the catalog lists it with the file parameters), checked with a message
    that says what a name is (pydantic's own 'should match pattern' would quote the regex)."""
    extra = {"x-shipped": folder, "pattern": SHIPPED_NAME_PATTERN, **field.pop("json_schema_extra", {})}
    return Field(json_schema_extra=extra, **field)


# the type of such a field: `robot_profile: ShippedName = shipped("robots", default=...)`
ShippedName = Annotated[str, AfterValidator(_shipped_name)]


def _kind(mode: int) -> str:
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISDIR(mode):
        return "a folder"
    return "not a regular file"


def not_regular(path: str | Path) -> str | None:
    """Why the file at `path` (symlinks followed) may not be read, without opening it: None for a
    regular file or a missing one (reading it later says 'not found')."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    return None if stat.S_ISREG(mode) else f"it is {_kind(mode)}, not a regular file"


def read_regular(path: str | Path, limit: int, label: str | None = None) -> bytes:
    """The bytes of the regular file at `path` (already resolved and allowed by the caller), read
    through one descriptor; InputFileError when it is missing, not regular or over `limit` bytes."""
    label = label or str(path)
    flags = os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise InputFileError(f"file not found: {label}") from None
    except OSError as e:
        raise InputFileError(f"file {label} cannot be read ({e.strerror})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise InputFileError(f"file {label} refused: it is {_kind(st.st_mode)}, not a regular file")
        if st.st_size > limit:
            raise InputFileError(f"file {label} is {st.st_size / 1e6:.1f} MB, over the {limit / 1e6:.0f} MB limit")
        chunks, total = [], 0
        while total <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > limit:
            raise InputFileError(f"file {label} grew over the {limit / 1e6:.0f} MB limit while being read")
        return b"".join(chunks)
    finally:
        os.close(fd)


def check_shipped_name(name: str, what: str, shipped: list[str]) -> None:
    """InputFileError unless `name` has the form of a shipped name (nothing is looked up)."""
    if not isinstance(name, str) or not name or len(name) > 128 or not SHIPPED_NAME.match(name):
        raise InputFileError(
            f"{what} {str(name)[:80]!r} is not a shipped name (letters, digits, _ - . without "
            f"'..' or '/'); shipped: {', '.join(shipped)}"
        )


def read_shipped(folder: Path, file_name: str, what: str, shipped: list[str], limit: int = 20_000_000) -> bytes:
    """A shipped data file by name (`file_name` = the name plus its extension) from `folder`."""
    check_shipped_name(file_name, what, shipped)
    path = folder / file_name
    try:
        return read_regular(path, limit, label=file_name)
    except InputFileError:
        raise InputFileError(f"{what} {file_name!r} not found (unknown name; shipped: {', '.join(shipped)})") from None
