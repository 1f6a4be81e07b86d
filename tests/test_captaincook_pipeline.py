"""pipelines/captaincook.mk end to end on the shipped CaptainCook4D files (SMALL=1): the rule
check, the converted recordings, training runs, step-recognition evaluation and the page."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import make_small

ROOT = Path(__file__).parent.parent


@pytest.mark.slow
def test_the_captaincook_pipeline_runs_on_the_shipped_files(tmp_path: Path) -> None:
    out = tmp_path / "cc"
    result = make_small("captaincook.mk", out, "-j2")
    assert result.returncode == 0, result.stderr[-2000:]
    page = (out / "captaincook4d.md").read_text()
    rows = [line for line in page.splitlines() if line.startswith(("| none |", "| exact |"))]
    assert len(rows) >= 2  # the step-recognition table, one row per method
    assert "wall time" in page and "breaking at least one rule" in page
    report = json.loads((out / "eval" / "step_recognition.json").read_text())
    assert {r["method"] for r in report["runs"]} == {"none", "exact"}
    for run in report["runs"]:
        counts = run["test_recordings"]
        assert counts["keep"] > 0 and counts["break"] > 0
        assert run["weight"] in report["weights"]
        val = run["val_step_accuracy"]
        assert val[run["weight"]] == max(val.values())  # soft's weight: the best on val
    assert make_small("captaincook.mk", out, "-q").returncode == 0  # nothing left to do


def test_the_pipeline_reads_only_the_repository() -> None:
    text = (ROOT / "pipelines" / "captaincook.mk").read_text()
    # no path climbs out of the repository; the data default is the shipped copy
    assert "../" not in text and "DATA ?= examples/captaincook4d" in text
