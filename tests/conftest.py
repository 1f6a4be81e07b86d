"""Shared fixtures: an isolated compile cache per test, exhaustive trace sets, SMALL pipelines."""

from __future__ import annotations

import itertools
import random
import re
import subprocess
import sys
from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory, monkeypatch) -> Path:
    """Every test gets its own compile cache, so no test sees another's (or the user's) cache."""
    cache = tmp_path_factory.mktemp("cache")
    monkeypatch.setenv("TLEAF_CACHE_DIR", str(cache))
    return cache


def all_traces(atoms, max_len: int, one_hot: bool = False) -> list[list[frozenset[str]]]:
    """Every non-empty trace up to max_len over the atoms (powerset or one-hot letters)."""
    if one_hot:
        letters = [frozenset()] + [frozenset({a}) for a in atoms]
    else:
        letters = [
            frozenset(c) for r in range(len(atoms) + 1) for c in itertools.combinations(atoms, r)
        ]
    return [list(t) for n in range(1, max_len + 1) for t in itertools.product(letters, repeat=n)]


@pytest.fixture(scope="session")
def chain_cli():
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    runner = CliRunner()
    return lambda *args: runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="session")
def chain(tmp_path_factory, chain_cli) -> dict[str, Path]:
    """A tiny synthetic chain: 40 low-tier formulas, 8 pairs each, q_e trained briefly."""
    from tleaf_cli.embed.train_edge import EdgeSettings, train_edge

    d = tmp_path_factory.mktemp("meta")
    p = {
        k: d / v
        for k, v in [
            ("ltl", "f.ltl"),
            ("dfas", "dfas.parquet"),
            ("traces", "traces.parquet"),
            ("edge", "edge"),
        ]
    }
    assert chain_cli("gen-formulas", "--tier", "low", "-n", 40, "-o", p["ltl"]).exit_code == 0
    assert chain_cli("compile-dfa", p["ltl"], "-o", p["dfas"]).exit_code == 0
    assert (
        chain_cli(
            "gen-traces", p["dfas"], "-o", p["traces"], "--per-formula", 8, "--split", "0.6,0.2,0.2"
        ).exit_code
        == 0
    )
    train_edge(p["dfas"], p["edge"], EdgeSettings(hidden=32, out_dim=16, epochs=3, per_guard=2))
    return p


def make_small(
    makefile: str, out: Path, *args: str, timeout: int = 600
) -> subprocess.CompletedProcess:
    """`make -f pipelines/<makefile> SMALL=1` with this venv's tleaf and Python (the report
    scripts read Parquet), output in `out`; `args` are further make flags or variables (e.g.
    "-q", "LOSSES=none tleaf")."""
    tleaf = Path(sys.executable).parent / "tleaf"
    command = ["make", "-f", f"pipelines/{makefile}", "SMALL=1", f"TLEAF={tleaf}",
               f"PYTHON={sys.executable}", f"OUT={out}"]  # fmt: skip
    root = Path(__file__).parent.parent
    return subprocess.run(
        [*command, *args], cwd=root, capture_output=True, text=True, timeout=timeout
    )


def shared_small(tmp_path_factory, makefile: str, *args: str, timeout: int = 600) -> Path:
    """`make_small(makefile, OUT, *args)` run once for the whole test run, its OUT returned (make's
    success asserted): with pytest-xdist the first worker to ask runs it, under a lock in the
    folder the workers of one run share, and the others wait for it and get the same OUT (a
    session fixture alone runs once per worker). For tests that read OUT or run `make -q` on it;
    one that changes OUT changes only what no other test reads."""
    import fcntl
    import json
    import os

    # a folder name make reads as one word (no "=", ":" or spaces)
    key = re.sub(r"[^A-Za-z0-9_.-]", "_", "-".join([makefile.removesuffix(".mk"), *args]))
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        root = tmp_path_factory.mktemp(key)
    else:  # <basetemp>/popen-gwN: its parent is this run's, shared by the workers
        root = tmp_path_factory.getbasetemp().parent / key
        root.mkdir(exist_ok=True)
    out, done = root / "small", root / "make.json"
    with open(root / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.is_file():
            result = make_small(makefile, out, *args, timeout=timeout)
            done.write_text(json.dumps([result.returncode, result.stderr[-2000:]]))
    returncode, stderr = json.loads(done.read_text())
    assert returncode == 0, stderr
    return out


@pytest.fixture(scope="session")
def captaincook_small(tmp_path_factory) -> Path:
    """pipelines/captaincook.mk SMALL=1 (`all`: the curve and the Table I chain), once a run."""
    return shared_small(tmp_path_factory, "captaincook.mk", "-j2")


def tiny_activities(folder: Path, unlabelled: int = 0) -> tuple[Path, Path]:
    """`gen-activities`' smallest useful set in `folder` (6 actions, 5 ingredients, 8 / 4 / 4
    train / val / test videos of 3-6 steps, and `unlabelled` unlabelled ones) and its knowledge
    base: (activities, kb)."""
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    data, kb = folder / "act.parquet", folder / "kb.ltl"
    args = ["--actions", 6, "--ingredients", 5, "--feature-dim", 8, "--train", 8, "--val", 4]
    args += ["--test", 4, "--unlabelled", unlabelled, "--min-steps", 3, "--max-steps", 6]
    result = CliRunner().invoke(
        app, ["gen-activities", "-o", str(data), "--kb-out", str(kb), *map(str, args)]
    )
    assert result.exit_code == 0, result.output
    return data, kb


def with_actions(data: Path, actions: list, out: Path) -> Path:
    """A copy of the activities file `data` at `out` whose `action` column is `actions` (one per
    row), written as the same kind of artifact: for tests that relabel some steps."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from tleaf_cli.data.artifacts import read_provenance, write_artifact

    table = pq.read_table(data)
    provenance = read_provenance(data)
    write_artifact(
        table.set_column(table.schema.get_field_index("action"), "action", pa.array(actions)),
        out, kind=provenance.kind, schema=provenance.schema, params=provenance.params,
        inputs=[],
    )  # fmt: skip
    return out


def resource_log(path: Path, cases: int = 40, seed: int = 0, interleave: bool = False) -> Path:
    """A CSV log with a resource: a by r1, then b by r2 (once or twice), then c by r3 (r4 in a
    tenth of the cases, so a model learns r3 for c). `interleave`: the cases of one day start
    a minute apart, so that their events interleave in time (a stream's order)."""
    rng = random.Random(seed)
    rows = ["case:concept:name,concept:name,time:timestamp,org:resource"]
    for i in range(cases):
        events = [("a", "r1")] + [("b", "r2")] * rng.choice([1, 2])
        events.append(("c", "r4" if i % 10 == 0 else "r3"))
        minute = i % 60 if interleave else 0
        for t, (act, res) in enumerate(events):
            rows.append(f"k{i},{act},2020-01-{1 + i % 28:02d}T{10 + t:02d}:{minute:02d}:00,{res}")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def resource_cases(folder: Path, cases: int = 40, interleave: bool = False) -> Path:
    """`resource_log` read by `tleaf read-log --attributes org:resource`: folder/cases.parquet."""
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    out = folder / "cases.parquet"
    log = resource_log(folder / "log.csv", cases, interleave=interleave)
    result = CliRunner().invoke(
        app, ["read-log", str(log), "-o", str(out), "--attributes", "org:resource", "-q"]
    )
    assert result.exit_code == 0, result.output
    return out
