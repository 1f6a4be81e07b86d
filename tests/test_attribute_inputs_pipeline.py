"""pipelines/attribute_inputs.mk end to end on the shipped BPI 2013 closed problems sample
(SMALL=1): per fold a run without and one reading the resource, the one chosen on val, the
knowledge on top of it, and the page."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import make_small

ROOT = Path(__file__).resolve().parents[1]
REPORT = ROOT / "pipelines" / "attribute_inputs_report.py"


def _report(*args: str) -> str:
    result = subprocess.run(
        [sys.executable, str(REPORT), *args], capture_output=True, text=True, check=True
    )
    return result.stdout.strip()


@pytest.mark.slow
def test_the_attribute_pipeline_chooses_on_val_and_adds_knowledge_to_the_choice(tmp_path):
    out = tmp_path / "ai"
    result = make_small("attribute_inputs.mk", out, "-j2")
    assert result.returncode == 0, result.stderr[-2000:]
    for k in (0, 1):
        fold = out / "mezini-closed" / f"fold{k}"
        val = {
            v: json.loads((fold / v / "metrics.json").read_text())["best"]["val_accuracy"]
            for v in ("none", "inputs")
        }
        chosen = (fold / "chosen.txt").read_text().strip()
        assert chosen == ("inputs" if val["inputs"] > val["none"] else "none")
        settings = {
            v: json.loads((fold / v / "config.json").read_text())["settings"]
            for v in ("none", "inputs")
        }
        assert settings["inputs"]["inputs"] == "org:resource" and not settings["none"]["inputs"]
        knowledge = json.loads((fold / "knowledge" / "config.json").read_text())["settings"]
        # the knowledge run rebuilds the chosen model: its model, grid choice and attributes
        for name in ("model", "hidden", "layers", "lr", "inputs"):
            assert knowledge[name] == settings[chosen][name], name
        assert "--inputs org:resource" in _report("--flags", str(fold / "inputs"))
        assert "--inputs" not in _report("--flags", str(fold / "none"))
    page = (out / "attribute_inputs.md").read_text()
    rows = [line for line in page.splitlines() if line.startswith("| mezini-closed | 2 |")]
    assert len(rows) == 1 and rows[0].count("±") >= 4
