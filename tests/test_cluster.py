"""`--cluster`: the parallel stages on a dask.distributed cluster (a local scheduler and workers,
separate processes on 127.0.0.1) write the same rows as `--jobs 1`, and survive a lost worker."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data import parallel

try:
    import distributed
except ImportError:  # the optional extra tleaf[cluster] is not installed
    distributed = None

needs_distributed = pytest.mark.skipif(distributed is None, reason="needs tleaf[cluster]")

runner = CliRunner()
TLEAF = Path(sys.executable).parent / "tleaf"


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


# Bounds on waits for a failing test only: a passing run never waits on a clock to decide.
PATIENCE = 120.0


@contextmanager
def _refusing_port() -> Iterator[int]:
    """A port on 127.0.0.1 that refuses connections while the context lasts: bound here and
    never listening, so no other process can take it meanwhile (a port closed again could be)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        yield s.getsockname()[1]


def _wait_until(done: Callable[[], object], what: str, alive: subprocess.Popen) -> None:
    """Poll `done` until true; fail naming `what` if `alive` ends first or PATIENCE passes."""
    deadline = time.monotonic() + PATIENCE
    while not done():
        assert alive.poll() is None, f"the process ended before {what}"
        assert time.monotonic() < deadline, f"no {what} within {PATIENCE:g} s"
        time.sleep(0.05)


def _scheduler_address(scheduler_file: Path) -> str | None:
    """The address in the scheduler's file, once the file is there and whole."""
    try:
        return json.loads(scheduler_file.read_text())["address"]
    except (OSError, ValueError, KeyError):
        return None


def _start_worker(
    address: str, name: str, log: Path, preload: Path | None = None
) -> subprocess.Popen:
    # --no-nanny: the worker is this process, so killing it loses the worker (no restart).
    cmd = [sys.executable, "-m", "distributed.cli.dask_worker", address, "--name", name]
    cmd += ["--nthreads", "1", "--no-nanny", "--no-dashboard", "--host", "127.0.0.1"]
    cmd += ["--preload", str(preload)] if preload else []
    return subprocess.Popen(cmd, stdout=log.open("wb"), stderr=subprocess.STDOUT)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """(address, client, logs folder, started processes): a scheduler and two workers."""
    logs = tmp_path_factory.mktemp("cluster")
    procs: list[subprocess.Popen] = []
    client = None
    try:
        # Port 0: the OS gives the scheduler a free port and it keeps it; it writes its address.
        scheduler_file = logs / "scheduler.json"
        cmd = [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1"]
        cmd += ["--port", "0", "--no-dashboard", "--scheduler-file", str(scheduler_file)]
        log = (logs / "scheduler.log").open("wb")
        procs.append(subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT))
        _wait_until(lambda: _scheduler_address(scheduler_file), "scheduler address", procs[0])
        address = _scheduler_address(scheduler_file)
        assert address is not None
        for k in range(2):
            procs.append(_start_worker(address, f"w{k}", logs / f"w{k}.log"))
        client = distributed.Client(address, timeout=PATIENCE, set_as_default=False)
        client.wait_for_workers(2, timeout=PATIENCE)
        yield address, client, logs, procs
    finally:
        if client is not None:
            client.close()
        for proc in reversed(procs):
            _stop(proc)


@pytest.fixture(scope="module")
def formulas(tmp_path_factory) -> dict[int, Path]:
    """200 generated formulas, and the first 30 of them, as .ltl files."""
    folder = tmp_path_factory.mktemp("formulas")
    big = folder / "f200.ltl"
    result = tleaf("gen-formulas", "--tier", "low", "-n", 200, "-q", "--no-cache", "-o", big)
    assert result.exit_code == 0, result.output
    lines = [ln for ln in big.read_text().splitlines() if ln and not ln.startswith("#")]
    small = folder / "f30.ltl"
    small.write_text("\n".join(lines[:30]) + "\n")
    return {200: big, 30: small}


def _rows(path: Path) -> list[dict]:
    return pq.read_table(path).to_pylist()


@needs_distributed
def test_cluster_writes_the_same_rows_as_one_job(cluster, formulas, tmp_path: Path) -> None:
    address = cluster[0]
    local, remote = tmp_path / "local", tmp_path / "remote"
    local.mkdir()
    remote.mkdir()
    for folder, how in ((local, ["--jobs", 1]), (remote, ["--cluster", address])):
        result = tleaf("compile-dfa", formulas[30], *how, "-q", "-o", folder / "dfas.parquet")
        assert result.exit_code == 0, result.output
        result = tleaf(
            "gen-traces", folder / "dfas.parquet", "--per-formula", 4, "--split", "0.8,0.1,0.1",
            *how, "-q", "-o", folder / "traces.parquet",
        )  # fmt: skip
        assert result.exit_code == 0, result.output
    for name in ("dfas.parquet", "traces.parquet"):
        assert _rows(remote / name) == _rows(local / name), name
    assert len(_rows(remote / "dfas.parquet")) == 30
    # The compile cache (of MONA's results) works on the workers: a second MONA run on the
    # cluster finds every formula there, and the rows are those progression gave.
    for again in ("again1.pq", "again2.pq"):
        result = tleaf(
            "compile-dfa", formulas[30], "--cluster", address, "--engine", "mona",
            "-o", tmp_path / again,
        )  # fmt: skip
        assert result.exit_code == 0, result.output
    assert "30 from cache" in result.output
    assert _rows(tmp_path / "again2.pq") == _rows(local / "dfas.parquet")


@needs_distributed
def test_unreachable_scheduler_from_env_var(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(parallel, "CONNECT_TIMEOUT", 2.0)  # refused at once: no race with it
    (tmp_path / "f.ltl").write_text("x1: F(a)\nx2: G(b)\n")
    with _refusing_port() as port:
        monkeypatch.setenv("TLEAF_CLUSTER", f"tcp://127.0.0.1:{port}")
        result = tleaf("compile-dfa", tmp_path / "f.ltl", "-q", "-o", tmp_path / "d.parquet")
    assert result.exit_code == 2
    assert "--cluster: cannot reach a dask scheduler at tcp://127.0.0.1:" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "d.parquet").exists()


def test_cluster_without_distributed(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed: ImportError
    (tmp_path / "d.parquet").write_bytes(b"")
    for args in (
        ["compile-dfa", tmp_path / "f.ltl", "--cluster", "tcp://127.0.0.1:8786"],
        ["gen-formulas", "-n", 3, "--cluster", "tcp://127.0.0.1:8786"],
    ):
        (tmp_path / "f.ltl").write_text("x1: F(a)\nx2: G(b)\n")
        result = tleaf(*args, "-q", "-o", tmp_path / "out")
        assert result.exit_code == 2, result.output
        assert "--cluster: needs the optional package distributed" in result.output
        assert "Traceback" not in result.output
        assert not (tmp_path / "out").exists()


# Preloaded by the doomed worker: the first formulas it is given leave a mark and never finish,
# so the test kills it while it is known to hold compile work, and the run cannot have ended.
STUCK_WORKER = """
import threading
from pathlib import Path

from tleaf_cli.data import compile_dfas


def _stuck(*args):
    Path({mark!r}).touch()
    threading.Event().wait()  # until the worker is killed


compile_dfas._compile_task = _stuck  # what the tasks sent here name (pickled by reference)
"""


@needs_distributed
def test_lost_worker_loses_no_rows(cluster, formulas, tmp_path: Path) -> None:
    address, client, logs, procs = cluster
    reference = tmp_path / "reference.parquet"
    assert tleaf("compile-dfa", formulas[200], "-q", "-o", reference).exit_code == 0
    mark, preload = tmp_path / "doomed-has-work", tmp_path / "stuck_worker.py"
    preload.write_text(STUCK_WORKER.format(mark=str(mark)))
    doomed = _start_worker(address, "doomed", logs / "doomed.log", preload)
    procs.append(doomed)
    client.wait_for_workers(3, timeout=PATIENCE)
    out = tmp_path / "out" / "dfas.parquet"
    out.parent.mkdir()
    run = subprocess.Popen(
        [TLEAF, "compile-dfa", formulas[200], "--no-cache", "--cluster", address, "-q", "-o", out],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    try:
        _wait_until(mark.exists, "the doomed worker got work", run)
        os.kill(doomed.pid, signal.SIGKILL)
        doomed.wait()
        assert run.poll() is None, "the run ended although a worker never finished its work"
        assert not out.exists()  # nothing written before every row is in
        output, _ = run.communicate(timeout=PATIENCE)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == 0, output.decode()
    assert [p.name for p in out.parent.iterdir()] == ["dfas.parquet"]  # no partial/temp file
    rows = _rows(out)
    assert len(rows) == 200
    assert rows == _rows(reference)
