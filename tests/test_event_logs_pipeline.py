"""pipelines/event_logs.mk end to end on the shipped Helpdesk sample (SMALL=1): both protocols'
runs, evaluations and the report page; and what it checks before anything runs."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

from tests.conftest import make_small

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_the_event_log_pipeline_runs_on_the_shipped_real_log(tmp_path: Path) -> None:
    out = tmp_path / "el"
    # AHEAD=1: a fold trains only once the fold before it is evaluated
    result = make_small("event_logs.mk", out, "-j2", "AHEAD=1")
    assert result.returncode == 0, result.stderr[-2000:]
    report, runs = (out / "event_logs.md").read_text().split("## Runs behind the rows")
    assert (out / "event_logs.runs.json").is_file()  # the record, beside the page, in OUT
    rows = [line for line in report.split("## λ")[0].splitlines() if line.startswith("| helpdesk")]
    assert len(rows) == 1  # one fold-mean row
    suffix = report.split("## Suffix")[1].splitlines()
    assert len([line for line in suffix if line.startswith("| helpdesk-400 |")]) == 2 * 4
    table = report.split("## λ")[1].split("## Suffix")[0]
    chosen = [line for line in table.splitlines() if line.startswith("| helpdesk-400 |")]
    assert len(chosen) == 4  # exact and tleaf, in each protocol: the λ chosen and candidates
    commands = [line for line in runs.splitlines() if line.startswith("| helpdesk-400 |")]
    assert len(commands) == 2 and "`RM_LOGS=helpdesk-400 DF_LOGS= LAMBDAS=" in commands[1]
    assert "not measured" not in runs  # every training's CPU time, as timed-tleaf measured it
    for fold in (0, 1):  # the λ-0 candidate is the reference every fold is compared with
        chosen = json.loads((out / f"rm/helpdesk-400/fold{fold}/exact/metrics.json").read_text())
        assert 0.0 in [c["lambda"] for c in chosen["lambda"]["candidates"]]
        assert (out / f"rm/helpdesk-400/fold{fold}/exact.times.tsv").is_file()
    for formula in ("strong", "weak"):  # decoding under the formula always satisfies it
        metrics = json.loads(
            (out / f"df/helpdesk-400/eval-none-{formula}/metrics.json").read_text()
        )
        assert all(row["rules"]["satisfying"] == 1.0 for row in metrics["suffix"].values())
    # a line per finished training and evaluation, each fold's evaluations before the next trains
    lines = result.stdout.splitlines()
    said = [line.split(":")[0] for line in lines if line.startswith(("rm/", "df/"))]
    assert "rm/helpdesk-400/fold0/exact" in said and "df/helpdesk-400/eval-tleaf-weak" in said
    assert said.index("rm/helpdesk-400/fold0/eval-tleaf") < said.index(
        "rm/helpdesk-400/fold1/exact"
    )
    mined = [line for line in result.stderr.splitlines() if "mined.ltl: " in line]
    assert len(mined) == 3 and all(" rules from " in line for line in mined)  # mine-declare's
    assert make_small("event_logs.mk", out, "-q", "AHEAD=1").returncode == 0  # nothing left


def make(*args: str) -> subprocess.CompletedProcess:
    """The pipeline's make, printing what it would run (-n)."""
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MAKELEVEL")}
    return subprocess.run(
        ["make", "-n", "-f", "pipelines/event_logs.mk", *args],
        cwd=ROOT, capture_output=True, text=True, env=env, timeout=60,
    )  # fmt: skip


def test_a_missing_input_stops_it_before_anything_runs(tmp_path: Path) -> None:
    data = tmp_path / "data"
    (data / "preprocessed").mkdir(parents=True)
    (data / "preprocessed" / "NewLog.csv").write_text("CaseID,ActivityID,CompleteTimestamp\n")
    done = make(f"DATA={data}", "RM_LOGS=NewLog", "DF_LOGS=")
    assert done.returncode == 2 and done.stdout == ""
    assert f"missing input: {data}/published/accuracy_raw_results.csv and 1 more" in done.stderr
    assert "PUBLISHED= runs without the peers' figures" in done.stderr
    done = make(f"DATA={data}", "RM_LOGS=NewLog Other", "DF_LOGS=", "PUBLISHED=")
    assert done.returncode == 2 and f"missing input: {data}/preprocessed/Other.csv" in done.stderr
    # a new log: its CSV in preprocessed/; the page and its record go to OUT unless PAGE= says
    done = make(f"DATA={data}", "RM_LOGS=NewLog", "DF_LOGS=", "PUBLISHED=", f"OUT={tmp_path}/o")
    assert done.returncode == 0, done.stderr
    assert f"-o {tmp_path}/o/event_logs.md" in done.stdout
    assert f"--runs {tmp_path}/o/event_logs.runs.json" in done.stdout
    assert "docs/results" not in done.stdout
    page = tmp_path / "page.md"
    done = make(f"DATA={data}", "RM_LOGS=NewLog", "DF_LOGS=", "PUBLISHED=", f"PAGE={page}")
    assert f"-o {page} " in done.stdout and f"--runs {tmp_path}/page.runs.json" in done.stdout
    done = make(f"DATA={data}", "RM_LOGS=NewLog", "DF_LOGS=", "REPORT=x.md")
    assert done.returncode == 2 and "PAGE=FILE.md names the page" in done.stderr


@pytest.mark.parametrize("gnu", [True, False])
def test_timed_tleaf_appends_wall_and_cpu_seconds(tmp_path: Path, gnu: bool) -> None:
    """With GNU time, or where /usr/bin/time is not installed: one line per call, its exit
    status passed on."""
    if gnu and not Path("/usr/bin/time").exists():
        pytest.skip("GNU time is not installed")
    times = tmp_path / "times.tsv"
    env = {**os.environ, "TLEAF_TIMES": str(times), "TLEAF_BIN": "python3"}
    if not gnu:
        env["TIMED_TLEAF_NO_GNU_TIME"] = "1"
    timed = [str(ROOT / "pipelines" / "timed-tleaf"), "-c"]
    spin = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.3: pass"
    assert subprocess.run([*timed, spin], env=env).returncode == 0
    assert subprocess.run([*timed, "raise SystemExit(3)"], env=env).returncode == 3
    rows = [line.split("\t") for line in times.read_text().splitlines() if line.count("\t") >= 3]
    assert len(rows) == 2 and rows[0][3].startswith("python3 -c")
    assert float(rows[0][1]) + float(rows[0][2]) >= 0.25  # CPU seconds, not zero
