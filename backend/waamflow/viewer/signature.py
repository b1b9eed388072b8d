"""Content signatures of node outputs, so re-publishing redraws only what changed.

A `Layered` value built by the engine carries one signature per layer (`sigs`); those are used
as they are. Otherwise (values built by hand, whole-part values such as meshes and simulation
results) the signature is a BLAKE2b digest of the value's content: the same content gives the
same signature whether or not it is the same Python object. Digests of objects seen before are
remembered per object (weakly), so re-publishing unchanged outputs costs no hashing.
"""

from __future__ import annotations

import hashlib
import weakref
from dataclasses import fields, is_dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from ..core.model import Layered

_memo: "weakref.WeakKeyDictionary[Any, str]" = weakref.WeakKeyDictionary()


def _feed(h, obj: Any) -> None:
    """Feed a value's content into hash `h` (arrays by bytes, geometry by WKB, dataclasses by field)."""
    if obj is None:
        h.update(b"N")
    elif isinstance(obj, np.ndarray):
        a = np.ascontiguousarray(obj)
        h.update(f"A{a.dtype.str}{a.shape}".encode())
        if a.dtype == object:
            for v in a.reshape(-1):
                _feed(h, v)
        else:
            h.update(a.tobytes())
    elif isinstance(obj, BaseGeometry):
        h.update(b"G")
        h.update(shapely.to_wkb(obj))
    elif isinstance(obj, (str, bytes, int, float, bool, np.generic)):
        h.update(f"{type(obj).__name__}:{obj!r}".encode())
    elif isinstance(obj, dict):
        h.update(f"D{len(obj)}".encode())
        for k in sorted(obj, key=repr):
            _feed(h, k)
            _feed(h, obj[k])
    elif isinstance(obj, (list, tuple)):
        h.update(f"L{len(obj)}".encode())
        if obj and all(type(v) is str for v in obj):  # per-segment zone ids: one update
            h.update("\x1f".join(obj).encode())
            return
        for v in obj:
            _feed(h, v)
    elif is_dataclass(obj):
        h.update(type(obj).__name__.encode())
        for f in fields(obj):
            h.update(f.name.encode())
            _feed(h, getattr(obj, f.name))
    elif hasattr(obj, "__dict__"):
        h.update(type(obj).__name__.encode())
        _feed(h, {k: v for k, v in vars(obj).items() if not k.startswith("_")})
    else:
        h.update(repr(obj).encode())


def digest(obj: Any) -> str:
    """Hex content digest of any value made of arrays, geometry, dataclasses and containers."""
    try:
        cached = _memo.get(obj)
    except TypeError:  # not weak-referenceable / unhashable
        cached = None
    if cached is not None:
        return cached
    h = hashlib.blake2b(digest_size=16)
    _feed(h, obj)
    out = h.hexdigest()
    try:
        _memo[obj] = out
    except TypeError:
        pass
    return out


def layer_signatures(value: Layered) -> list[str | None]:
    """One signature per item of a Layered value: the engine's `sigs` when it set them, else
    content digests; None for missing items (partial runs)."""
    if value.sigs and len(value.sigs) == len(value.items):
        return [None if item is None else str(sig) for item, sig in zip(value.items, value.sigs)]
    return [None if item is None else digest(item) for item in value.items]
