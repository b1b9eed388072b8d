"""A bounded memo for pure kernels that meet the same input again and again.

A part's layers repeat: the 300 layers of graphs/bracket.json have 123 distinct sections (the
plate, the web, the web again above the window, and the window's sides, which change with every
layer of the diamond), so planning each section's path anew plans most of them several times.
A kernel keys its inputs exactly (`digest` of the bytes of the coordinates, a spec's JSON: never
a rounded value) and asks `Memo.get(key, compute)`; a hit returns the value computed for the
same bytes, so the result is the one a fresh computation gives, to the bit. Keys are 16-byte
BLAKE2b digests, so a long-lived process (a preview worker) holds no copies of old inputs.

Each process has its own memo (the layer workers too); entries are dropped least recently used
first past `size`. Values must not be mutated by callers: a kernel that hands out arrays hands
out copies (see paths/whole.py).
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from typing import Callable, Generic, Hashable, TypeVar

T = TypeVar("T")


def digest(*parts: bytes | str | float | bool | None) -> bytes:
    """16-byte BLAKE2b of `parts`, each tagged with its type and length (so b"ab", b"c" and b"a",
    b"bc" differ, and so do 1, 1.0 and True); floats by their exact repr."""
    h = hashlib.blake2b(digest_size=16)
    for part in parts:
        if part is None:
            data, tag = b"", b"n"
        elif isinstance(part, bytes):
            data, tag = part, b"b"
        elif isinstance(part, str):
            data, tag = part.encode("utf-8"), b"s"
        elif isinstance(part, bool):
            data, tag = b"1" if part else b"0", b"t"
        else:
            data, tag = repr(float(part)).encode(), b"f"
        h.update(tag + len(data).to_bytes(8, "little") + data)
    return h.digest()


class Memo(Generic[T]):
    """key → value, at most `size` entries, least recently used dropped first; thread-safe."""

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ValueError(f"memo size must be at least 1 (got {size})")
        self.size = size
        self._data: OrderedDict[Hashable, T] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get(self, key: Hashable, compute: Callable[[], T]) -> T:
        """The value stored under `key`, else `compute()` stored and returned (an exception of
        `compute` propagates and stores nothing)."""
        with self._lock:
            if key in self._data:
                self._data.move_to_end(key)
                self.hits += 1
                return self._data[key]
        value = compute()  # outside the lock: another thread may compute the same key meanwhile
        with self._lock:
            self.misses += 1
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self.size:
                self._data.popitem(last=False)
        return value

    def clear(self) -> None:
        with self._lock:
            self._data.clear()
            self.hits = self.misses = 0

    def __len__(self) -> int:
        return len(self._data)
