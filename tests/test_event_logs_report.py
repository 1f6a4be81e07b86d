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


def fold(
    out: Path, log: str, k: int, none: float, exact: float, rules: float | None = None,
    chosen: float = 0.1, cpu: float | None = None,
) -> None:  # fmt: skip
    """The two evaluations and the exact run (its λ candidates, the one chosen on val) of one
    fold, as the pipeline writes them; `rules`: the exact run's accuracy under the mined rules
    (default: its argmax accuracy); `cpu`: the training's CPU seconds, as timed-tleaf writes."""
    base = out / "rm" / log / f"fold{k}"
    for name, acc, under in (("eval-none", none, none), ("eval-exact", exact, rules or exact)):
        (base / name).mkdir(parents=True)
        metrics = {"accuracy": {"accuracy": acc, "accuracy_rules": under, "prefixes": 100},
                   "suffix": {}, "scored_cases": 10}  # fmt: skip
        (base / name / "metrics.json").write_text(json.dumps(metrics))
    candidates = []
    for lam, val in ((0, 0.70), (0.1, 0.71), (1, 0.57)):
        run = base / "exact" / "lambda-choice" / f"lambda-{lam:g}"
        run.mkdir(parents=True)
        metrics = {"task": "next-activity", "history": [{"seconds": 20.0}] * 2,
                   "lambda": {"value": lam, "source": "given", "candidates": []}}  # fmt: skip
        (run / "metrics.json").write_text(json.dumps(metrics))
        candidates.append(
            {"lambda": lam, "val_accuracy": val, "run": f"lambda-choice/lambda-{lam:g}"}
        )
    choice = {"value": chosen, "source": "validation", "candidates": candidates}
    metrics = {"task": "next-activity", "history": [{"seconds": 20.0}] * 2, "lambda": choice,
               "test": {"accuracy": exact}}  # fmt: skip
    (base / "exact" / "metrics.json").write_text(json.dumps(metrics))
    if cpu is not None:
        (base / "exact.times.tsv").write_text(f"500.00\t{cpu - 5:.2f}\t5.00\ttleaf train-task\n")


def report(out: Path | None, page: Path, runs: Path, *invocation: str) -> str:
    """The page, written by the report script from `out` (None: from the record alone)."""
    done = subprocess.run(
        [sys.executable, str(REPORT), *([] if out is None else [str(out)]), "-o", str(page),
         "--runs", str(runs), *invocation],
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
    # 2 logs x 2 folds x 3 candidates x 40 s of epochs; no training timed
    assert "training CPU time not measured; the training epochs took 8.0 minutes" in text
    assert "| SEPSIS | Rama-Maneiro (5 folds) | `RM_LOGS=SEPSIS DF_LOGS= LAMBDAS=1` |" in text
    assert "| Helpdesk | Rama-Maneiro (5 folds) | `RM_LOGS=Helpdesk DF_LOGS=` (settings not" in text
    assert text.rstrip().endswith("| 4.0 | not measured |")  # SEPSIS's 2 x 3 x 40 s
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


def test_folds_above_equal_and_below_and_every_lambda_candidate_are_shown(tmp_path: Path) -> None:
    out = tmp_path / "out"
    fold(out, "BPI12A", 0, 0.80, 0.80, rules=0.81)  # above
    fold(out, "BPI12A", 1, 0.80, 0.80, chosen=0)  # λ 0: the reference itself, equal
    fold(out, "BPI12A", 2, 0.80, 0.80, rules=0.79)  # below
    text = report(out, tmp_path / "page.md", tmp_path / "runs.json")
    row = next(line for line in text.splitlines() if line.startswith("| BPI12A | 3 |"))
    assert "| 1 / 1 / 1 |" in row and "accuracy moved in 2 of 3 folds" in row
    # the λ each fold chose, and the candidate that collapsed on val, rejected
    assert (
        "| BPI12A | Rama-Maneiro | exact | 0.1, 0, 0.1 | λ 0: 70.00 (70.00) · λ 0.1: 71.00 " in text
    )
    assert "λ 1: 57.00 (57.00) |" in text


def test_cpu_time_is_the_timed_trainings_and_the_reference_counts_once(tmp_path: Path) -> None:
    out = tmp_path / "out"
    for k in range(2):
        fold(out, "Helpdesk", k, 0.8, 0.8, cpu=90.0)
    # the tleaf run's λ-0 candidate is the exact run's reference, copied: its epochs count once
    reference = out / "rm/Helpdesk/fold0/exact/lambda-choice/lambda-0/metrics.json"
    copy = out / "rm/Helpdesk/fold0/tleaf/lambda-choice/lambda-0/metrics.json"
    copy.parent.mkdir(parents=True)
    copy.write_text(reference.read_text())
    text = report(out, tmp_path / "page.md", tmp_path / "runs.json")
    assert "3.0 CPU minutes of training; the training epochs took 4.0 minutes" in text
    assert text.rstrip().endswith("| 4.0 | 3.0 |")


def published(folder: Path, logs: list[str]) -> Path:
    folder.mkdir()
    rows = ["accuracy,approach,fold,log"]
    rows += [f"{acc},{who},0,{log}" for log in logs for who, acc in (("Tax", 0.79), ("TACO", 0.9))]
    (folder / "accuracy_raw_results.csv").write_text("\n".join(rows) + "\n")
    (folder / "apriori_suffix_dl.csv").write_text(
        "log,formula,method,prefix_length,dl_similarity\n"
    )
    return folder


def test_goals_count_the_pipeline_logs_and_an_unpublished_log_says_so(tmp_path: Path) -> None:
    out = tmp_path / "out"
    for k in range(4):
        fold(out, "Helpdesk", k, 0.80, 0.80, rules=0.81)
        fold(out, "BPI_Challenge_2012_A", k, 0.80, 0.80, rules=0.81)
    peers = published(tmp_path / "published", ["helpdesk"])
    text = report(out, tmp_path / "page.md", tmp_path / "runs.json", "--published", str(peers),
                  "--rm-all", "Helpdesk SEPSIS")  # fmt: skip
    assert "| Helpdesk | 4 | 80.00 ± 0.00 |" in text and "| 79.00 | 90.00 (TACO) |" in text
    assert "| BPI_Challenge_2012_A | 4 |" in text and "— (none published) |" in text
    # the goals count the pipeline's logs run (2 named, 1 run), not the new log
    assert (
        "at or above Tax et al.: 1 of the 1 logs run that they measured (goal: all of the " in text
    )
    assert "in at least 4 of 5 folds: 1 of 1 logs run (goal: all of the pipeline's 2)" in text
    assert "not counted above (not among the pipeline's logs): BPI_Challenge_2012_A." in text
    assert (
        "no published figures for BPI_Challenge_2012_A (looked up as `bpi_challenge_2012_a`)"
        in text
    )
    assert "| SEPSIS | 0 (not in the record: `RM_LOGS=SEPSIS`) |" in text
    # the record keeps the pipeline's logs: the page rewritten from it alone counts the same
    again = report(None, tmp_path / "page.md", tmp_path / "runs.json", "--published", str(peers))
    assert again == text


def test_a_missing_published_file_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "published").mkdir()
    done = subprocess.run(
        [sys.executable, str(REPORT), str(tmp_path), "-o", str(tmp_path / "p.md"),
         "--published", str(tmp_path / "published")],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 1 and done.stderr.count("\n") == 1
    assert done.stderr.startswith("error: ") and "accuracy_raw_results.csv" in done.stderr


def test_a_finished_step_says_what_it_found(tmp_path: Path) -> None:
    out = tmp_path / "out"
    fold(out, "Helpdesk", 0, 0.80, 0.80, rules=0.81, cpu=90.0)

    def say(step: str) -> str:
        done = subprocess.run(
            [sys.executable, str(REPORT), str(out), "--say", str(out / step)],
            capture_output=True, text=True,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        return done.stdout

    assert say("rm/Helpdesk/fold0/exact") == (
        "rm/Helpdesk/fold0/exact: λ 0.1 chosen on validation among 0 (70.00 %), 0.1 (71.00 %), "
        "1 (57.00 %); test accuracy 80.00 %; 1.5 CPU min\n"
    )
    assert say("rm/Helpdesk/fold0/eval-exact") == (
        "rm/Helpdesk/fold0/eval-exact: test accuracy 80.00 %, under the rules 81.00 %\n"
    )


def test_the_suffix_goals_count_the_pipeline_logs(tmp_path: Path) -> None:
    out = tmp_path / "out"
    row = {"cases": 10, "argmax": {"dl_similarity": 0.5}, "beam": {"dl_similarity": 0.6},
           "rules": {"dl_similarity": 0.7, "satisfying": 1.0, "not_found": 0}}  # fmt: skip
    for log in ("helpdesk", "mylog"):
        for name in ("eval-none-strong", "eval-none-strong-mined"):
            (out / "df" / log / name).mkdir(parents=True)
            metrics = {"accuracy": {"accuracy": 0.5}, "suffix": {"2": row}, "scored_cases": 10}
            (out / "df" / log / name / "metrics.json").write_text(json.dumps(metrics))
    text = report(out, tmp_path / "page.md", tmp_path / "runs.json", "--df-all", "helpdesk bpi_11")
    assert "| mylog | strong | 2 | 10 |" in text  # shown, not counted
    assert "satisfying: 1 of 1 cells (goal: every cell)" in text
    assert "1 of 1 logs run (goal: all of the pipeline's 2)" in text
    assert "not counted above (not among the pipeline's logs): mylog." in text
