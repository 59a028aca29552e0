"""ufmt.recent.Recent: the last few values by key, least recently used dropped first."""

import threading

import pytest

from ufmt.recent import Recent


def test_keeps_the_last_keys_and_drops_the_least_recently_used():
    built = []
    memo = Recent(2)

    def value(key):
        return memo.get(key, lambda: built.append(key) or key * 10)

    assert [value(1), value(2), value(1)] == [10, 20, 10]  # 1 is now the most recent
    assert value(3) == 30  # drops 2, not 1
    assert value(1) == 10 and value(2) == 20  # 2 is built again
    assert built == [1, 2, 3, 2] and len(memo) == 2
    memo.clear()
    assert len(memo) == 0


def test_a_failed_build_keeps_nothing():
    memo = Recent(4)

    def fail():
        raise ValueError("bad design")

    with pytest.raises(ValueError):
        memo.get("k", fail)
    assert len(memo) == 0
    assert memo.get("k", lambda: 1) == 1


def test_threads_get_the_value_of_their_key():
    memo = Recent(3)
    results = {}

    def worker(i):
        results[i] = [memo.get(i % 5, lambda i=i: i % 5) for _ in range(200)]

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(values == [i % 5] * 200 for i, values in results.items())
    assert len(memo) <= 3
