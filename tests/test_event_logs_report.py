"""pipelines/event_logs_report.py: runs measured by separate invocations add up in the record of
runs, and the page is written from all of them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

REPORT = Path(__file__).resolve().parents[1] / "pipelines" / "event_logs_report.py"


def fold(out: Path, log: str, k: int, none: float, exact: float) -> None:
    """The two evaluations and the exact run's candidates of one fold, as the pipeline writes."""
    base = out / "rm" / log / f"fold{k}"
    for name, acc in (("eval-none", none), ("eval-exact", exact)):
        (base / name).mkdir(parents=True)
        metrics = {"accuracy": {"accuracy": acc, "accuracy_rules": acc}, "suffix": {},
                   "scored_cases": 10}  # fmt: skip
        (base / name / "metrics.json").write_text(json.dumps(metrics))
    for lam in (0, 0.1):
        run = base / "exact" / "lambda-choice" / f"lambda-{lam:g}"
        run.mkdir(parents=True)
        metrics = {"task": "next-activity", "history": [{"seconds": 30.0}] * 2}
        (run / "metrics.json").write_text(json.dumps(metrics))


def report(out: Path, page: Path, runs: Path, *invocation: str) -> str:
    done = subprocess.run(
        [sys.executable, str(REPORT), str(out), "-o", str(page), "--runs", str(runs),
         *invocation],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return page.read_text()


def test_invocations_on_other_logs_add_up_and_a_rerun_replaces(tmp_path: Path) -> None:
    runs, page = tmp_path / "runs.json", tmp_path / "page.md"
    first, second, again = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    for k in range(2):
        fold(first, "Helpdesk", k, 0.80, 0.81)
        fold(second, "SEPSIS", k, 0.60, 0.62)
        fold(again, "Helpdesk", k, 0.70, 0.71)
    text = report(first, page, runs)
    assert "| Helpdesk | 2 |" in text and "SEPSIS" not in text
    text = report(second, page, runs, "--logs", "rm/SEPSIS", "--settings", "LAMBDAS=1")
    # the first invocation's log stays on the page; each log's command is the one that ran it
    assert "| Helpdesk | 2 | 80.00" in text and "| SEPSIS | 2 | 60.00" in text
    assert "8.0 CPU minutes of training" in text  # 2 logs x 2 folds x 2 candidates x 60 s
    assert "| SEPSIS | Rama-Maneiro (5 folds) | `RM_LOGS=SEPSIS DF_LOGS= LAMBDAS=1` |" in text
    assert "| Helpdesk | Rama-Maneiro (5 folds) | `RM_LOGS=Helpdesk DF_LOGS=` (settings not" in text
    assert text.rstrip().endswith("| 4.0 |")  # SEPSIS's 2 folds x 2 candidates x 60 s
    text = report(again, page, runs, "--rm-all", "Helpdesk env_permit")
    # the same paths measured again: the new figures; a pipeline log not run says so
    assert "| Helpdesk | 2 | 70.00" in text and "| SEPSIS | 2 | 60.00" in text
    assert "| env_permit | 0 (not in the record: `RM_LOGS=env_permit`) |" in text
    assert "| Helpdesk | 0" not in text and "| SEPSIS | 0" not in text
    kept = json.loads(runs.read_text())  # one wall time per log, the latest measure of it
    assert sorted(kept["walls"]) == ["rm/Helpdesk", "rm/SEPSIS"]
    late = time.time() + 3 * 3600  # a log run hours later into the same folder: its own wall
    fold(second, "BPI12", 0, 0.5, 0.5)
    for path in (second / "rm" / "BPI12").rglob("*"):
        os.utime(path, (late, late))
    text = report(second, page, runs)
    kept = json.loads(runs.read_text())
    assert sorted(kept["walls"]) == ["rm/BPI12", "rm/Helpdesk", "rm/SEPSIS"]
    assert max(kept["walls"].values()) < 60 and "(summed over 3 log runs)" in text
