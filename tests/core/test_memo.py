"""core.memo: a bounded, least-recently-used memo for pure kernels."""

import threading

import pytest

from waamflow.core.memo import Memo


def test_hit_returns_the_stored_value_without_computing():
    memo: Memo[int] = Memo(4)
    calls = []

    def compute(v):
        calls.append(v)
        return v * 10

    assert memo.get(b"a", lambda: compute(1)) == 10
    assert memo.get(b"a", lambda: compute(2)) == 10  # not computed again
    assert memo.get(b"b", lambda: compute(3)) == 30
    assert calls == [1, 3]
    assert (memo.hits, memo.misses, len(memo)) == (1, 2, 2)


def test_least_recently_used_is_dropped_past_the_size():
    memo: Memo[str] = Memo(2)
    memo.get("a", lambda: "A")
    memo.get("b", lambda: "B")
    memo.get("a", lambda: "never")  # a is now the most recent
    memo.get("c", lambda: "C")  # drops b
    assert len(memo) == 2
    assert memo.get("a", lambda: "again") == "A"
    assert memo.get("b", lambda: "B2") == "B2"  # recomputed: it had been dropped
    assert (memo.hits, memo.misses) == (2, 4)


def test_an_exception_stores_nothing():
    memo: Memo[int] = Memo(2)

    def boom() -> int:
        raise ValueError("no")

    with pytest.raises(ValueError):
        memo.get("k", boom)
    assert len(memo) == 0 and memo.get("k", lambda: 7) == 7


def test_size_must_be_positive_and_clear_empties():
    with pytest.raises(ValueError, match="at least 1"):
        Memo(0)
    memo: Memo[int] = Memo(3)
    memo.get(1, lambda: 1)
    memo.clear()
    assert (len(memo), memo.hits, memo.misses) == (0, 0, 0)


def test_threads_get_the_one_value_per_key():
    memo: Memo[int] = Memo(1000)
    out: list[int] = []

    def work():
        for k in range(200):
            out.append(memo.get(k, lambda k=k: k * k))

    ts = [threading.Thread(target=work) for _ in range(4)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert len(out) == 800 and sorted(set(out)) == [k * k for k in range(200)]
    assert len(memo) == 200


def test_digest_tells_parts_apart_and_is_stable():
    from waamflow.core.memo import digest

    d = digest(b"ab", b"c", 1.5, True, None, "x")
    assert len(d) == 16 and d == digest(b"ab", b"c", 1.5, True, None, "x")
    others = [
        digest(b"a", b"bc", 1.5, True, None, "x"),  # the same bytes split elsewhere
        digest(b"ab", b"c", 1.5000000000000002, True, None, "x"),  # one ulp
        digest(b"ab", b"c", 1.5, False, None, "x"),
        digest(b"ab", b"c", 1.5, True, b"", "x"),  # None is not empty bytes
        digest(b"ab", b"c", 1.5, True, None, b"x"),  # str is not bytes
        digest(b"ab", b"c", 1.5, 1.0, None, "x"),  # True is not 1.0
    ]
    assert len({d, *others}) == 7
