"""Readers that take only a path (OpenCascade's STEP/IGES readers, ezdxf's binary DXF) given bytes."""

from __future__ import annotations

import os
import tempfile
from typing import Callable, TypeVar

T = TypeVar("T")


def read_through_file(data: bytes, suffix: str, reader: Callable[[str], T]) -> T:
    """`reader(path)` of `data` written to a temporary file with `suffix` (e.g. ".step"); the file is
    removed afterwards, whatever the reader does."""
    fd, path = tempfile.mkstemp(suffix=suffix)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        return reader(path)
    finally:
        os.unlink(path)
