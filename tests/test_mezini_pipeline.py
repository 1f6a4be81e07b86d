"""pipelines/mezini.mk on a log other than the bundled one, with DATA= alone: a synthetic folder
in the layout of examples/knowledge-protocols/mezini-bpic13-closed/ (other activities, longer
cases, a Declare model naming an activity no log has, their per-run figures for some prefix
lengths only). The settings and the model come from the data, each written in the run's record,
and the report fills its tables for the prefix lengths that ran. On the bundled BPI 2013 closed
data the same settings as before: prefixes 1-3, the longest suffix 18, the two Not Co-Existence
constraints on Accepted_Assigned left out, kb.decl as `grep -v Accepted_Assigned` wrote it."""

from __future__ import annotations

import csv
import gzip
import json
import os
import random
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import make_small

ROOT = Path(__file__).resolve().parents[1]
BPIC13 = ROOT / "examples" / "knowledge-protocols" / "mezini-bpic13-closed"

# every case: submitted, checked and notified some times, approved or rejected, archived
DECL = """activity Submit form
activity Check docs
activity Notify client
activity Approve
activity Reject
activity Archive
activity Escalate
bind Escalate: org:resource
org:resource: Ann, Bob
Existence[Submit form] | |
Response[Submit form, Archive] | | |
Not Co-Existence[Escalate, Approve] | | |
Not Co-Existence[Approve, Reject] | | |
Response[Escalate, Notify client] | | |
Existence[Escalate] | |
"""


def case(rng: random.Random, middle: int) -> list[str]:
    loop = [rng.choice(["Check docs", "Notify client"]) for _ in range(middle)]
    return ["Submit form", *loop, rng.choice(["Approve", "Reject"]), "Archive"]


def write_xes(path: Path, cases: list[list[str]], first_day: int) -> None:
    """A gzipped XES log, one trace per case (in time order), an event a minute apart."""
    traces = []
    for i, acts in enumerate(cases):
        day = first_day + i
        events = "".join(
            f'<event><string key="concept:name" value="{a}"/>'
            f'<string key="org:resource" value="Ann"/>'
            f'<date key="time:timestamp" value="2020-{1 + day // 28:02d}-{1 + day % 28:02d}'
            f'T10:{j:02d}:00+00:00"/></event>'
            for j, a in enumerate(acts)
        )
        traces.append(f'\t<trace><string key="concept:name" value="c{day}"/>{events}</trace>')
    text = '<?xml version="1.0" encoding="UTF-8" ?>\n<log xes.version="1.0">\n'
    with gzip.open(path, "wt", encoding="utf-8") as f:
        f.write(text + "\n".join(traces) + "\n</log>\n")


def synthetic_data(folder: Path) -> None:
    """40 training cases of 4-12 events (median 7: prefixes 3-5), 12 test cases of 4-21 (the
    longest suffix 21), the training log at 40 % noise relabelled among the log's activities;
    their figures at noise 40 for prefix lengths 3 and 4, none for 5, beside another log's (as
    their results/paper_results.csv holds every log)."""
    rng = random.Random(0)
    folder.mkdir()
    train = [case(rng, m) for m in [1, 2, 3, 3, 4, 4, 4, 4, 5, 6, 8, 9] * 3 + [2, 3, 4, 5]]
    rng.shuffle(train)
    test = [case(rng, m) for m in [1, 2, 3, 4, 4, 4, 5, 6, 7, 8, 10, 18]]
    activities = sorted({a for c in train for a in c})
    noisy = [[rng.choice(activities) if rng.random() < 0.4 else a for a in c] for c in train]
    write_xes(folder / "train_80_all.xes.gz", train, 0)
    write_xes(folder / "train_80_all_04n.xes.gz", noisy, 0)
    write_xes(folder / "test_20_all.xes.gz", test, 100)
    (folder / "test_all_85-100.decl").write_text(DECL)
    with open(folder / "paper_results_synthetic.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["architecture", "dataset", "noise", "alpha", "run_id", "loss",
                    "prefix_length", "sampling_strategy", "test_similarity_scaled",
                    "test_satisfiability"])  # fmt: skip
        for log, shift in (("synthetic", 0.0), ("other", 0.2)):
            for run in (1, 2):
                for loss, sim in (("baseline", 0.61), ("LLL", 0.64), ("GLL", 0.58)):
                    for prefix in (3, 4, 5) if log == "other" else (3, 4):
                        for strategy in ("greedy", "temperature"):
                            w.writerow(["LSTM", log, 40, 0.65, run, loss, prefix, strategy,
                                        sim + shift + prefix / 100, 1.0])  # fmt: skip


def rows(text: str, title: str) -> dict[str, list[str]]:
    """The table after `title`: prefix -> its cells (the 40 % rows)."""
    table = text.split(title)[1].split("\n\n")[1]
    out = {}
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells[0] == "40 %":
            out[cells[1]] = cells[2:]
    return out


@pytest.mark.slow
def test_another_log_runs_with_data_alone(tmp_path: Path) -> None:
    data, out = tmp_path / "data", tmp_path / "out"
    synthetic_data(data)
    args = (f"DATA={data}", "NOISES=40", "LOSSES=exact")
    # their CSV holds two logs: refused, naming them, before anything trains
    done = make_small("mezini.mk", out, *args, timeout=300)
    assert done.returncode == 2 and "rows of 2 logs (other, synthetic): set DATASET=" in done.stderr
    assert not (out / "n40" / "s0").exists()
    done = make_small("mezini.mk", out, *args, "DATASET=synthetic", timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    record = json.loads((out / "record.json").read_text())
    # the settings from the data, as their runner takes them, each with where it came from
    assert record["prefixes"]["value"] == record["prefixes"]["data"] == "3-5"
    assert "m = 7 the median length of the training cases" in record["prefixes"]["from"]
    assert record["max_suffix"]["value"] == 21
    assert "the test log's longest case" in record["max_suffix"]["from"]
    commands = (out / "times.tsv").read_text()
    assert "--prefix-lengths 3-5" in commands and "--max-suffix 21" in commands
    # the constraints over Escalate, which no log has, left out and recorded with why
    kb = (out / "kb.decl").read_text()
    assert "Escalate" not in kb and "Not Co-Existence[Approve, Reject]" in kb
    assert kb.count("\n") == DECL.count("\n") - 5  # 3 constraints, its activity and bind lines
    dropped = {d["constraint"]: d for d in record["kb"]["dropped"]}
    assert sorted(dropped) == [
        "Existence[Escalate]",
        "Not Co-Existence[Escalate, Approve]",
        "Response[Escalate, Notify client]",
    ]
    assert all(d["absent"] == ["Escalate"] for d in dropped.values())
    assert all("no case of the training or test logs has" in d["why"] for d in dropped.values())
    assert dropped["Response[Escalate, Notify client]"]["breaks"] == 0  # vacuous here
    assert (
        dropped["Existence[Escalate]"]["breaks"] > 0
        and "looser" in (dropped["Existence[Escalate]"]["why"])
    )
    # the report: tleaf's figures at every prefix length that ran, theirs where they have them
    report = (out / "mezini.md").read_text()
    assert "prefix lengths 3, 4, 5" in report
    assert "Existence[Escalate]" in report and "Prefix lengths 3-5: their runner's" in report
    assert "Their figures: the 24 rows of" in report and "for synthetic" in report
    for title in ("**Greedy (argmax):**", "**Sampled at temperature 0.7:**"):
        table = rows(report, title)
        assert sorted(table) == ["3", "4", "5"]
        for prefix, cells in table.items():
            ours, theirs = cells[:-3], cells[-3:]
            assert len(ours) == 4 and "–" not in ours, (prefix, cells)
            if prefix == "5":
                assert theirs == ["–", "–", "–"]  # their CSV has no prefix 5
            else:
                strategy_sim = 0.61 + int(prefix) / 100
                assert theirs[0] == f"{strategy_sim:.3f} / 1.00", (prefix, cells)
    wins = report.split("**Seeds where")[1].split("\n\n")[1]
    assert "| 40 % | 3 |" in wins and "| 40 % | 4 |" in wins and "–" not in wins
    lam = rows(report, "**exact: the λ chosen on validation**")
    assert lam  # the λ table's figures at prefixes 3 / 4
    assert "at prefixes 3 / 4" in report and "–" not in " ".join(lam.get("0", []))


def make_n(*args: str) -> subprocess.CompletedProcess:
    """The pipeline's make, printing what it would run (-n)."""
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MAKELEVEL")}
    return subprocess.run(
        ["make", "-n", "-f", "pipelines/mezini.mk", f"PYTHON={sys.executable}", *args],
        cwd=ROOT, capture_output=True, text=True, env=env, timeout=60,
    )  # fmt: skip


def test_the_bundled_log_keeps_its_settings_and_others_override_them(tmp_path: Path) -> None:
    done = make_n("SMALL=1")
    assert done.returncode == 0, done.stderr
    evals = [line for line in done.stdout.splitlines() if " eval next-activity " in line]
    assert len(evals) == 6  # 2 noise levels, λ 0 and 1 of exact, 0.01 of tleaf
    assert all("--prefix-lengths 1-3 --temperature 0.7 --max-suffix 18 " in e for e in evals)
    assert f"--published {BPIC13.relative_to(ROOT)}/paper_results_bpic13_closed.csv" in done.stdout
    assert "PREFIXES=1-3 MAX_SUFFIX=18" in done.stdout
    kb = next(line for line in done.stdout.splitlines() if "mezini_data.py kb" in line)
    assert "--record out/mezini-small/record.json" in kb
    done = make_n("SMALL=1", "PREFIXES=2,4", "MAX_SUFFIX=30")
    assert done.returncode == 0, done.stderr
    assert "--prefix-lengths 2,4 --temperature 0.7 --max-suffix 30 " in done.stdout
    # another log: its settings from its data, and no peers' figures unless DATA has them
    data = tmp_path / "data"
    synthetic_data(data)
    (data / "paper_results_synthetic.csv").unlink()
    done = make_n("SMALL=1", f"DATA={data}", "NOISES=40")
    assert done.returncode == 0, done.stderr
    assert "--prefix-lengths 3-5 --temperature 0.7 --max-suffix 21 " in done.stdout
    assert "--published" not in done.stdout
    # their repository's plain .xes are read as they are
    for name in ("train_80_all_04n", "test_20_all"):
        with gzip.open(data / f"{name}.xes.gz", "rb") as f:
            (data / f"{name}.xes").write_bytes(f.read())
        (data / f"{name}.xes.gz").unlink()
    done = make_n("SMALL=1", f"DATA={data}", "NOISES=40")
    assert done.returncode == 0, done.stderr
    assert f"join {data}/train_80_all_04n.xes {data}/test_20_all.xes " in done.stdout
    assert "--prefix-lengths 3-5 --temperature 0.7 --max-suffix 21 " in done.stdout


@pytest.mark.slow
def test_the_bundled_model_loses_the_same_two_constraints(tmp_path: Path) -> None:
    """mezini_data.py kb on BPI 2013 closed's clean and 40 % logs: kb.decl byte for byte as
    `grep -v Accepted_Assigned` wrote it, the two constraints recorded as holding anyway."""
    tleaf = Path(sys.executable).parent / "tleaf"
    script = ROOT / "pipelines"
    cases = []
    for name in ("train_80_all", "train_80_all_04n"):
        joined = tmp_path / name / "joined.xes"
        joined.parent.mkdir()
        subprocess.run(
            [sys.executable, str(script / "mezini_report.py"), "join",
             str(BPIC13 / f"{name}.xes.gz"), str(BPIC13 / "test_20_all.xes.gz"), "-o", str(joined)],
            check=True, capture_output=True,
        )  # fmt: skip
        split = joined.with_suffix(".split").read_text().strip()
        cases.append(tmp_path / name / "cases.parquet")
        subprocess.run(
            [str(tleaf), "read-log", str(joined), "-o", str(cases[-1]), "--split", split,
             "--split-order", "file", "-q"],
            check=True, capture_output=True,
        )  # fmt: skip
    decl = BPIC13 / "test_all_85-100.decl"
    done = subprocess.run(
        [sys.executable, str(script / "mezini_data.py"), "kb", str(decl), *map(str, cases),
         "-o", str(tmp_path / "kb.decl"), "--record", str(tmp_path / "record.json")],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    kept = [line for line in decl.read_text().split("\n") if "Accepted_Assigned" not in line]
    assert (tmp_path / "kb.decl").read_text() == "\n".join(kept)
    record = json.loads((tmp_path / "record.json").read_text())["kb"]
    assert [d["constraint"] for d in record["dropped"]] == [
        "Not Co-Existence[Accepted_Assigned, Completed_Closed]",
        "Not Co-Existence[Accepted_Assigned, Accepted_In Progress]",
    ]
    assert all(d["breaks"] == 0 for d in record["dropped"])
