"""The on-disk cache of monitor shares (`data.monitor_cache`): a hit returns what of_dfa computes
without computing it, and a changed DFA set, bank or broken file is computed again."""

from __future__ import annotations

import numpy as np
import pytest

from tleaf_cli.data.monitor_cache import monitor_shares
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.monitors import MonitorBank

FORMULAS = ("F(a) & G(!b)", "(a U b)", "G(a -> X(b))")


@pytest.fixture
def dfas():
    return [compile_formula(f) for f in FORMULAS]


def _files(cache) -> list:
    return sorted((cache / "monitors").glob("*.npy"))


def test_a_hit_is_what_of_dfa_computes_and_computes_nothing(dfas, tmp_path, monkeypatch):
    bank = MonitorBank(2, max_length=6, ranges=2)
    first = monitor_shares(dfas, bank, tmp_path)
    assert first.shape == (3, 2, bank.features) and first.dtype == np.float32
    assert np.array_equal(first, np.stack([bank.of_dfa(d) for d in dfas]))
    assert len(_files(tmp_path)) == 1

    def refuse(dfa):
        raise AssertionError("computed although cached")

    monkeypatch.setattr(bank, "of_dfa", refuse)
    assert np.array_equal(monitor_shares(dfas, bank, tmp_path), first)


def test_another_set_order_or_bank_is_another_entry(dfas, tmp_path):
    bank = MonitorBank(2, max_length=6)
    monitor_shares(dfas, bank, tmp_path)
    swapped = monitor_shares(dfas[::-1], bank, tmp_path)
    assert np.array_equal(swapped, np.stack([bank.of_dfa(d) for d in dfas[::-1]]))
    other = MonitorBank(2, max_length=6, ranges=3)
    assert monitor_shares(dfas, other, tmp_path).shape == (3, 2, other.features)
    assert len(_files(tmp_path)) == 3


def test_a_broken_file_is_computed_again_and_replaced(dfas, tmp_path):
    bank = MonitorBank(2, max_length=6)
    good = monitor_shares(dfas, bank, tmp_path)
    (path,) = _files(tmp_path)
    path.write_bytes(b"not an array")
    assert np.array_equal(monitor_shares(dfas, bank, tmp_path), good)
    assert np.array_equal(np.load(path), good)


def test_without_the_cache_nothing_is_written(dfas, tmp_path):
    bank = MonitorBank(2, max_length=6)
    shares = monitor_shares(dfas, bank, tmp_path, use_cache=False)
    assert np.array_equal(shares, np.stack([bank.of_dfa(d) for d in dfas]))
    assert not (tmp_path / "monitors").exists()
    assert monitor_shares([], bank, tmp_path).shape == (0, 2, bank.features)


def test_of_two_processes_at_once_one_computes_and_the_other_reads(dfas, tmp_path, monkeypatch):
    """make -j starts a tier's trainings together: the second waits on the set's lock and
    reads the first one's file instead of computing the same shares again.

    Ordered by events, not by sleeping: the second starts once the first is computing, and the
    first finishes only once the second has found the lock held (a non-blocking try refused),
    so the second always contends for the lock while the first holds it."""
    import fcntl
    import threading

    from tleaf_cli.data import monitor_cache

    bank = MonitorBank(2, max_length=6, ranges=2)
    computing, contended = threading.Event(), threading.Event()
    computed: list[bool] = []  # per computation: whether the other one contended meanwhile
    real_compute, real_flock = monitor_cache._compute, fcntl.flock

    def compute_once_contended(dfas, bank):
        computing.set()
        computed.append(contended.wait(timeout=60))  # a bound for a failing test only
        return real_compute(dfas, bank)

    def flock(fd, operation: int) -> None:
        if operation == fcntl.LOCK_EX:
            try:
                real_flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return
            except BlockingIOError:  # held by the other thread: it is computing
                contended.set()
        real_flock(fd, operation)

    monkeypatch.setattr(monitor_cache, "_compute", compute_once_contended)
    monkeypatch.setattr(fcntl, "flock", flock)
    results: dict[str, np.ndarray] = {}
    errors: list[BaseException] = []

    def shares(name: str) -> None:
        try:
            results[name] = monitor_shares(dfas, bank, tmp_path)
        except BaseException as e:  # reported in the test's thread below
            errors.append(e)

    first = threading.Thread(target=shares, args=("first",))
    second = threading.Thread(target=shares, args=("second",))
    first.start()
    assert computing.wait(timeout=60), "the first never started computing"
    second.start()
    for thread in (first, second):
        thread.join(timeout=120)
        assert not thread.is_alive()
    assert not errors, errors
    assert computed == [True]  # computed once, while the second waited on the lock
    assert contended.is_set() and results.keys() == {"first", "second"}
    assert np.array_equal(results["first"], results["second"])
