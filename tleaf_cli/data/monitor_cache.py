"""The monitor shares of a set of DFAs, kept on disk between processes.

`MonitorBank.of_dfa` is exact and costs about 33 ms per High-tier DFA: the model-checking
pipeline asked for the same 1,000 DFAs' shares six times per tier (q_m's training and its
evaluation, three seeds each), about 200 s of CPU on High. `monitor_shares` computes them once
per (DFA set, bank) and keeps them as one .npy file under the compile cache's folder
(`$TLEAF_CACHE_DIR`, else `~/.cache/tleaf`), `monitors/<key>.npy`.

The key is a SHA-256 of everything the shares depend on: the bank (its monitors' tables and
accepting states, slots, maximum length, ranges, and `logic.monitors.SHARES_VERSION`, raised
whenever `of_dfa`'s arithmetic changes) and each DFA (alphabet, transition table, initial and
accepting states) in order. A file is written whole (temporary file, then rename), and a
process that finds another computing the same set (a lock file beside it) waits for its file
instead of computing it too; a file that cannot be read is computed again. The folder only ever
grows (14 MB per set of 1,000 DFAs with the pipeline's bank); delete it to reclaim the space.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from tleaf_cli.data.artifacts import atomic_path
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.monitors import SHARES_VERSION, MonitorBank
from tleaf_cli.settings.data import default_cache_dir


def monitor_shares(
    dfas: Sequence[DFA], bank: MonitorBank, cache_dir: Path | None = None, use_cache: bool = True
) -> np.ndarray:
    """[len(dfas), 2, features] float32: `bank.of_dfa` of every DFA, from the cache where this
    set was computed before (`cache_dir`: default `default_cache_dir()`; `use_cache=False`
    computes and writes nothing)."""
    if not use_cache or not dfas:
        return _compute(dfas, bank)
    path = Path(cache_dir or default_cache_dir()) / "monitors" / f"{_key(dfas, bank)}.npy"
    expected = (len(dfas), 2, bank.features)
    shares = _load(path, expected)
    if shares is None:
        with _computing(path):  # another process computing this set: wait, then read its file
            shares = _load(path, expected)
            if shares is None:
                shares = _compute(dfas, bank)
                _write_atomic(path, shares)
    return shares


def _load(path: Path, expected: tuple[int, ...]) -> np.ndarray | None:
    try:
        shares = np.load(path)
        if shares.shape == expected and shares.dtype == np.float32:
            return shares
    except (OSError, ValueError):
        pass  # not there yet, or unreadable: compute it again
    return None


@contextlib.contextmanager
def _computing(path: Path) -> Iterator[None]:
    """Hold the set's lock file while computing it (`make -j` starts a tier's q_m trainings
    together: one computes, the others wait for its file instead of computing it too). Where
    no lock can be taken (no fcntl, a read-only cache), each process computes on its own."""
    try:
        import fcntl

        path.parent.mkdir(parents=True, exist_ok=True)
        lock = open(path.with_suffix(".lock"), "w")  # noqa: SIM115 (held across the yield)
    except (ImportError, OSError):
        yield
        return
    with lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield


def _compute(dfas: Sequence[DFA], bank: MonitorBank) -> np.ndarray:
    if not dfas:
        return np.zeros((0, 2, bank.features), dtype=np.float32)
    return np.stack([bank.of_dfa(dfa) for dfa in dfas])


def _key(dfas: Sequence[DFA], bank: MonitorBank) -> str:
    digest = hashlib.sha256()
    settings = (SHARES_VERSION, bank.slots, bank.max_length, bank.ranges, bank.tables.shape)
    digest.update(repr(settings).encode())
    digest.update(bank.tables.astype(np.int64).tobytes())
    digest.update(bank.accepting.astype(bool).tobytes())
    for dfa in dfas:
        head = (dfa.alphabet.atoms, dfa.alphabet.kind, dfa.initial, dfa.table.shape)
        digest.update(repr(head).encode())
        digest.update(dfa.table.tobytes())
        digest.update(dfa.accepting.tobytes())
    return digest.hexdigest()


def _write_atomic(path: Path, shares: np.ndarray) -> None:
    """Write the file whole or not at all; a cache that cannot be written is only slower."""
    try:
        temporary = atomic_path(path)
    except OSError:
        return
    try:
        with open(temporary, "wb") as file:
            np.save(file, shares)
        os.replace(temporary, path)
    except OSError:
        pass
    finally:
        temporary.unlink(missing_ok=True)
