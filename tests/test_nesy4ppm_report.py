"""pipelines/nesy4ppm_report.py: figures pooled over prefix lengths by rows, mean ± sd over seeds,
and the goals judged per seed, on fabricated evaluations."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

SPEC = importlib.util.spec_from_file_location(
    "nesy4ppm_report", Path(__file__).parent.parent / "pipelines" / "nesy4ppm_report.py"
)
report_module = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(report_module)

RES = "org:resource"


def _way(dl: float, res: float, sat: float, ms: float = 1.0) -> dict:
    return {
        "dl_similarity": dl,
        f"dl_similarity_{RES}": res,
        "jaccard": dl,
        f"jaccard_{RES}": res,
        "satisfying": sat,
        "ms_per_case": ms,
    }


def _metrics(soft: dict, rows=(30, 10)) -> dict:
    plain = _way(0.8, 0.2, 0.0)
    suffix = {
        str(k + 1): {"cases": n, "argmax": plain, "beam": plain, "rules": plain, "beam_soft": soft,
                     "argmax_soft": soft}
        for k, n in enumerate(rows)
    }  # fmt: skip
    return {"suffix": suffix}


def _write(root: Path, seed: int, weight: str, metrics: dict) -> None:
    path = root / "transformer" / f"seed{seed}" / f"eval-w{weight}" / "metrics.json"
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps(metrics))


def test_pooled_weights_prefix_lengths_by_rows():
    metrics = _metrics(_way(0.9, 0.7, 1.0))
    metrics["suffix"]["2"]["beam_soft"] = _way(0.5, 0.3, 0.0)
    figures = report_module.pooled(metrics, "beam_soft")
    assert figures["rows"] == 40
    assert figures["dl_similarity"] == pytest.approx((0.9 * 30 + 0.5 * 10) / 40)
    assert figures["satisfying"] == pytest.approx(0.75)


def test_goals_count_the_seeds_that_meet_each(tmp_path):
    _write(tmp_path, 0, "20", _metrics(_way(0.85, 0.70, 1.0)))
    _write(tmp_path, 1, "20", _metrics(_way(0.84, 0.70, 1.0)))  # under 0.842 on activities
    text = report_module.report(tmp_path, ["transformer"], ["0", "1"], ["20"])
    goal = next(line for line in text.splitlines() if line.startswith("- transformer"))
    assert "DL of activities ≥ 0.842: not met (1 of 2 seeds)" in goal
    assert "DL of resources ≥ 0.688: met (2 of 2)" in goal
    assert "compliance 1.000: met (2 of 2)" in goal
    row = next(line for line in text.splitlines() if "soft μ 20" in line and "beam" in line)
    assert "0.845 ± 0.007" in row  # mean ± sd of 0.85 and 0.84


def test_the_best_soft_weight_is_judged(tmp_path):
    for w, dl in (("1", 0.82), ("20", 0.86)):
        _write(tmp_path, 0, w, _metrics(_way(dl, 0.7, 1.0)))
    text = report_module.report(tmp_path, ["transformer"], ["0"], ["1", "20"])
    assert "- transformer, beam + knowledge, soft μ 20:" in text
