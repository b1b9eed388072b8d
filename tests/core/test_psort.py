"""core.psort: the halves sorted on two threads and merged give what one sort gives."""

import numpy as np
import pytest

from waamflow.core import psort


@pytest.mark.parametrize("n", [0, 1, 7, psort.MIN_SPLIT - 1, psort.MIN_SPLIT, psort.MIN_SPLIT + 1, 2_500_003])
@pytest.mark.parametrize("dtype", [np.uint64, np.int64, np.int32])
def test_the_same_array_as_one_sort(n, dtype, monkeypatch):
    monkeypatch.setattr(psort.os, "cpu_count", lambda: 2)
    rng = np.random.default_rng(n)
    info = np.iinfo(dtype)
    a = rng.integers(info.min // 2, info.max // 2, n, dtype=dtype)
    a[: n // 3] = a[n // 3 : 2 * (n // 3)]  # duplicates across the halves
    want = np.sort(a)
    psort.sort_inplace(a)
    np.testing.assert_array_equal(a, want)


def test_split_only_when_large_and_on_two_cores(monkeypatch):
    started = []
    real = psort.threading.Thread

    def spy(*a, **k):
        started.append(k.get("name"))
        return real(*a, **k)

    monkeypatch.setattr(psort.threading, "Thread", spy)
    big = np.arange(psort.MIN_SPLIT, 0, -1, dtype=np.int64)
    monkeypatch.setattr(psort.os, "cpu_count", lambda: 1)
    psort.sort_inplace(big.copy())
    psort.sort_inplace(np.arange(10, 0, -1))
    assert started == []
    monkeypatch.setattr(psort.os, "cpu_count", lambda: 2)
    b = big.copy()
    psort.sort_inplace(b)
    assert started == ["waamflow-sort"] and b[0] == 1 and b[-1] == psort.MIN_SPLIT
    f = np.array([3.0, 1.0, 2.0] * psort.MIN_SPLIT)  # floats: the plain sort (NaN order is numpy's)
    psort.sort_inplace(f)
    assert started == ["waamflow-sort"] and f[0] == 1.0 and f[-1] == 3.0
