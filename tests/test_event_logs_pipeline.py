"""pipelines/event_logs.mk end to end on the shipped Helpdesk sample (SMALL=1): both protocols'
runs, evaluations and the report page."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import make_small


@pytest.mark.slow
def test_the_event_log_pipeline_runs_on_the_shipped_real_log(tmp_path: Path) -> None:
    out = tmp_path / "el"
    result = make_small("event_logs.mk", out, "-j2")
    assert result.returncode == 0, result.stderr[-2000:]
    report, runs = (out / "event_logs.md").read_text().split("## Runs behind the rows")
    rows = [line for line in report.splitlines() if line.startswith("| helpdesk-400 |")]
    assert len(rows) == 1 + 2 * 4  # one fold-mean row; strong and weak at prefix lengths 2-5
    commands = [line for line in runs.splitlines() if line.startswith("| helpdesk-400 |")]
    assert len(commands) == 2 and "`RM_LOGS=helpdesk-400 DF_LOGS= LAMBDAS=" in commands[1]
    for fold in (0, 1):  # the λ-0 candidate is the reference every fold is compared with
        chosen = json.loads((out / f"rm/helpdesk-400/fold{fold}/exact/metrics.json").read_text())
        assert 0.0 in [c["lambda"] for c in chosen["lambda"]["candidates"]]
    for formula in ("strong", "weak"):  # decoding under the formula always satisfies it
        metrics = json.loads(
            (out / f"df/helpdesk-400/eval-none-{formula}/metrics.json").read_text()
        )
        assert all(row["rules"]["satisfying"] == 1.0 for row in metrics["suffix"].values())
    assert make_small("event_logs.mk", out, "-q").returncode == 0  # nothing left to do
