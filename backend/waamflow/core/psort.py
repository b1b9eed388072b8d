"""Sorting a large integer array on two cores.

numpy sorts on one core, and lets go of the GIL while it does: the halves of an array sorted in
two threads at once, then the whole sorted again with a stable sort (timsort finds the two sorted
runs and merges them in one pass), gives the very array one `ndarray.sort` gives, in about half
the time when a second core is free: a 1,008,000-triangle mesh read sorts 3 M vertex keys and
3 M edge keys, 0.17 s each on one core, 0.09 s so (numpy 2.4, 2 cores). With one core, or a small
array, it is the plain sort.
"""

from __future__ import annotations

import os
import threading

import numpy as np

MIN_SPLIT = 1_000_000  # elements: below, the threads' start and the merge cost more than they save


def sort_inplace(a: np.ndarray) -> None:
    """Sort the 1-D integer array `a` in place (ascending), the halves in two threads when it is
    large and there is a second core."""
    n = len(a)
    if n < MIN_SPLIT or (os.cpu_count() or 1) < 2 or a.ndim != 1 or a.dtype.kind not in "iu":
        a.sort()
        return
    half = n // 2
    other = threading.Thread(target=a[half:].sort, name="waamflow-sort")
    other.start()
    a[:half].sort()
    other.join()
    a.sort(kind="stable")  # two sorted runs: one merge
