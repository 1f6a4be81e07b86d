"""pipelines/captaincook.mk's Table I chain on real traces (SMALL=1: four recipes, tiny q's): the
recipe formulas, the held-out recipes' recordings as test traces, one q per preset evaluated on
them and on the synthetic test traces, and the page section."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from tests.conftest import make_small


@pytest.mark.slow
def test_the_table1_chain_runs_on_the_shipped_files(captaincook_small: Path) -> None:
    """The chain as the whole pipeline's run made it (its page ends with this section), shared
    with tests/test_captaincook_pipeline.py, which changes only the page's curve part."""
    out = captaincook_small
    python = f"PYTHON={sys.executable}"
    section = out / "table1" / "section.md"
    t1 = out / "table1"
    recorded = [
        r
        for r in pq.read_table(t1 / "recording_traces.parquet").to_pylist()
        if r["source"] == "recorded"
    ]
    assert recorded and {r["split"] for r in recorded} == {"test"}
    for preset in ("best", "paper"):
        real = json.loads((t1 / "seed0" / f"eval-{preset}-real" / "report.json").read_text())
        assert real["test_traces"] == len(recorded)  # every held-out recording was scored
        synthetic = t1 / "seed0" / f"eval-{preset}-synthetic" / "report.json"
        assert json.loads(synthetic.read_text())["test_formulas"] == real["test_formulas"]
    text = section.read_text()
    rows = [line for line in text.splitlines() if line.startswith(("| best |", "| paper |"))]
    assert len(rows) == 2 and "wall time" in text
    assert make_small("captaincook.mk", out, python, "-q", str(section)).returncode == 0
