"""pipelines/next_activity_models.mk end to end on the shipped Helpdesk sample (SMALL=1): every
model's runs and evaluations, the best model chosen on validation, the knowledge run on top of
it, and the page; and what it checks before anything runs."""

from __future__ import annotations

import json
import os
import re
import statistics
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import make_small

ROOT = Path(__file__).resolve().parents[1]
REPORT = ROOT / "pipelines" / "next_activity_models_report.py"
FIGURE = r"\d+\.\d\d ± \d+\.\d\d"  # a mean ± sd over the folds


def json_of(path: Path) -> dict:
    return json.loads(path.read_text())


@pytest.mark.slow
def test_the_models_pipeline_runs_on_the_shipped_real_log(tmp_path: Path) -> None:
    out = tmp_path / "nam"
    # AHEAD=1: a fold trains only once the fold before it is evaluated
    result = make_small("next_activity_models.mk", out, "-j2", "AHEAD=1")
    assert result.returncode == 0, result.stderr[-2000:]
    page = (out / "next_activity_models.md").read_text()
    assert (out / "next_activity_models.runs.json").is_file()  # the record, beside the page
    table = page.split("## Next-activity accuracy")[1].split("## What the leaders read")[0]
    rows = [line for line in table.splitlines() if line.startswith("| helpdesk-400 |")]
    assert len(rows) == 1  # one row per log: the fold means
    cells = [c.strip() for c in rows[0].strip("|").split("|")]
    assert cells[1] == "2"  # folds
    for cell in (cells[2], *cells[4:8]):  # prefix table, LSTM, Transformer, best, knowledge
        assert re.fullmatch(rf"\**{FIGURE}\**", cell), cell
    assert re.fullmatch(r"\d+ / \d+ / \d+", cells[8]) and sum(map(int, cells[8].split("/"))) == 2
    assert "(written by hand)" in page.split("## What the leaders read")[1].split("## ")[0]

    best_test = []
    for fold in (out / "helpdesk-400" / f"fold{k}" for k in (0, 1)):
        # the best model: the grid-chosen run with the higher val accuracy (ties: the LSTM)
        val = {m: json_of(fold / m / "metrics.json")["best"]["val_accuracy"]
               for m in ("lstm", "transformer")}  # fmt: skip
        best = (fold / "best.txt").read_text().strip()
        assert best == ("lstm" if val["lstm"] >= val["transformer"] else "transformer")
        for m in ("lstm", "transformer"):  # each chosen on its grid's val accuracies
            grid = json_of(fold / m / "metrics.json")["grid"]
            assert len(grid["candidates"]) == 2
            assert val[m] == max(c["val_accuracy"] for c in grid["candidates"])
        best_test.append(json_of(fold / f"eval-{best}" / "metrics.json")["accuracy"]["accuracy"])
        # the knowledge run: the best model's settings, its λ-0 candidate the best run itself
        knowledge = json_of(fold / "knowledge" / "metrics.json")["lambda"]
        zero = [c for c in knowledge["candidates"] if c["lambda"] == 0]
        assert len(zero) == 1 and zero[0]["val_accuracy"] == val[best]
        assert len(knowledge["candidates"]) == 3  # 0, 0.1, 1
        weights = (fold / "knowledge" / "lambda-choice" / "lambda-0" / "weights.pt").read_bytes()
        assert weights == (fold / best / "weights.pt").read_bytes()
        ours = json_of(fold / "knowledge" / "config.json")["settings"]
        theirs = json_of(fold / best / "config.json")["settings"]
        for key in ("model", "hidden", "layers", "lr"):
            assert ours[key] == theirs[key]
        evaluated = json_of(fold / "eval-knowledge" / "metrics.json")["accuracy"]
        assert "accuracy_rules" in evaluated  # predicted under the mined rules
        assert (fold / "knowledge.times.tsv").is_file()  # timed
    # the bold column is the chosen model's test accuracy, fold by fold
    assert cells[6].startswith(f"**{100 * statistics.mean(best_test):.2f} ± ")
    choices = page.split("## The configuration chosen")[1].split("## How to read")[0]
    assert len([line for line in choices.splitlines() if line.startswith("| helpdesk-400 |")]) == 2
    said = [line.split(":")[0] for line in result.stdout.splitlines()]
    assert "helpdesk-400/fold0/knowledge" in said and "helpdesk-400/fold1/eval-knowledge" in said
    assert said.index("helpdesk-400/fold0/eval-knowledge") < said.index("helpdesk-400/fold1/lstm")
    costs = page.split("## Cost and commands")[1]
    row = [line for line in costs.splitlines() if line.startswith("| helpdesk-400 |")]
    assert len(row) == 1 and "`LOGS=helpdesk-400 SMALL=1 " in row[0]
    assert make_small("next_activity_models.mk", out, "-q", "AHEAD=1").returncode == 0  # done

    # the page from its record alone keeps the hand-written section
    target = out / "next_activity_models.md"
    target.write_text(page.replace("(written by hand)", "The leaders read X.\n\nAnd Y."))
    done = subprocess.run(
        [sys.executable, str(REPORT), "-o", str(target), "--runs",
         str(out / "next_activity_models.runs.json")],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    again = target.read_text()
    assert "The leaders read X.\n\nAnd Y.\n\n## The configuration chosen" in again
    assert rows[0] in again


def make(*args: str) -> subprocess.CompletedProcess:
    """The pipeline's make, printing what it would run (-n)."""
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MAKELEVEL")}
    return subprocess.run(
        ["make", "-n", "-f", "pipelines/next_activity_models.mk", *args],
        cwd=ROOT, capture_output=True, text=True, env=env, timeout=60,
    )  # fmt: skip


def test_a_missing_input_stops_it_before_anything_runs(tmp_path: Path) -> None:
    data = tmp_path / "data"
    (data / "preprocessed").mkdir(parents=True)
    (data / "preprocessed" / "NewLog.csv").write_text("CaseID,ActivityID,CompleteTimestamp\n")
    done = make(f"DATA={data}", "LOGS=NewLog")
    assert done.returncode == 2 and done.stdout == ""
    assert f"missing input: {data}/published/accuracy_raw_results.csv" in done.stderr
    assert '"Data for the published comparisons"' in done.stderr
    done = make(f"DATA={data}", "LOGS=NewLog Other", "PUBLISHED=")
    assert done.returncode == 2 and f"missing input: {data}/preprocessed/Other.csv" in done.stderr
    assert "DATA=PATH is required" in make("LOGS=NewLog").stderr
    # the page and its record go to OUT unless PAGE= names them
    done = make(f"DATA={data}", "LOGS=NewLog", "PUBLISHED=", f"OUT={tmp_path}/o")
    assert done.returncode == 0, done.stderr
    assert f"-o {tmp_path}/o/next_activity_models.md" in done.stdout
    assert "docs/results" not in done.stdout
    assert '--grid "hidden=64,100 layers=1,2 lr=0.001,0.002"' in done.stdout
    assert '--grid "hidden=36,64 layers=1,2 lr=0.001,0.002"' in done.stdout
    assert done.stdout.count("--folds 5 --fold") == 5
    page = tmp_path / "page.md"
    done = make(f"DATA={data}", "LOGS=NewLog", "PUBLISHED=", f"PAGE={page}")
    assert f"-o {page} " in done.stdout and f"--runs {tmp_path}/page.runs.json" in done.stdout


def test_flags_rebuild_a_grid_chosen_model(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    grid = "model=lstm,transformer hidden=36,64 dropout=0.1,0.2"  # the model among the fields
    settings = {"model": "transformer", "grid": grid, "hidden": 36, "layers": 1, "lr": 0.002,
                "dropout": 0.1, "batch_size": 32}  # fmt: skip
    (run / "config.json").write_text(json.dumps({"settings": settings}))
    done = subprocess.run([sys.executable, str(REPORT), "--flags", str(run)],
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 0, done.stderr
    flags = "--model transformer --hidden 36 --dropout 0.1 --layers 1 --lr 0.002"
    assert done.stdout.strip() == flags
