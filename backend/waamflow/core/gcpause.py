"""The cyclic garbage collector paused while a phase builds millions of objects that hold no
reference cycles: a program's plan (one `Motion` per toolpath point), its text's lines, the
read-back's points. Each allocation burst set off the collector, whose oldest generation walks
every live object each time: on a 1.76-million-point program (a 0.55 m ball's contour fill),
plan 4.3 → 2.5 s, G-code text 6.2 → 4.2 s, read-back 4.0 → 3.4 s (17 full collections that freed
nothing). Reference counting frees everything as usual; cycles made meanwhile wait for the next
collection after the phase."""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def paused_gc() -> Iterator[None]:
    """Cyclic GC off inside, back to what it was after (an exception too). Nested or from several
    threads: the collector is re-enabled by the outermost pause that found it enabled."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()
