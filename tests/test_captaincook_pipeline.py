"""pipelines/captaincook.mk end to end on the shipped CaptainCook4D files (SMALL=1): the rule
check, the converted recordings, training runs, step-recognition evaluation and the page."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import make_small

ROOT = Path(__file__).parent.parent


@pytest.mark.slow
def test_the_captaincook_pipeline_runs_on_the_shipped_files(captaincook_small: Path) -> None:
    out = captaincook_small  # make's success asserted there
    page = (out / "captaincook4d.md").read_text()
    rows = [line for line in page.splitlines() if line.startswith(("| none |", "| exact |"))]
    assert len(rows) >= 2  # the step-recognition table, one row per method
    assert "wall time" in page and "breaking at least one rule" in page
    report = json.loads((out / "eval" / "step_recognition.json").read_text())
    assert {r["method"] for r in report["runs"]} == {"none", "exact", "tleaf"}
    for run in report["runs"]:
        counts = run["test_recordings"]
        assert counts["keep"] > 0 and counts["break"] > 0
        assert run["weight"] in report["weights"]
        val = run["val_step_accuracy"]
        assert val[run["weight"]] == max(val.values())  # soft's weight: the best on val
    # each logic loss chose its λ on val among its candidates and 0, the λ-0 candidate being
    # the run without a logic loss of the same size and seed (taken, not trained again)
    none = json.loads((out / "runs" / "none-n8-seed0" / "metrics.json").read_text())
    for loss, lam in (("exact", 1.0), ("tleaf", 0.002)):  # SMALL's candidates besides 0
        run = out / "runs" / f"{loss}-n8-seed0"
        choice = json.loads((run / "metrics.json").read_text())["lambda"]
        assert choice["source"] == "validation"
        assert sorted(c["lambda"] for c in choice["candidates"]) == [0.0, lam]
        zero = json.loads((run / "lambda-choice" / "lambda-0" / "metrics.json").read_text())
        assert zero["history"] == none["history"]
    config = json.loads((out / "runs" / "tleaf-n8-seed0" / "config.json").read_text())
    assert config["settings"]["logic_loss"] == "tleaf" and (out / "q" / "meta").is_dir()
    assert make_small("captaincook.mk", out, "-q").returncode == 0  # nothing left to do
    # curve-page rewrites the curve part with the losses asked for (here without tleaf) and
    # keeps the page's Table I section as it was
    table1 = page[page.index("<!-- captaincook-table1") :]
    (out / "eval" / "step_recognition.md").unlink()
    again = make_small("captaincook.mk", out, "curve-page", "LOSSES=none exact")
    assert again.returncode == 0, again.stderr[-2000:]
    page = (out / "captaincook4d.md").read_text()
    assert page.endswith(table1) and "curve-page`" in page and 'LOSSES="none exact"' in page
    assert not any(line.startswith("| tleaf |") for line in page.splitlines())


def test_the_pipeline_reads_only_the_repository() -> None:
    text = (ROOT / "pipelines" / "captaincook.mk").read_text()
    # no path climbs out of the repository; the data default is the shipped copy
    assert "../" not in text and "DATA ?= examples/captaincook4d" in text
