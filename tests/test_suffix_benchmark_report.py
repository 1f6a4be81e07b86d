"""The suffix benchmark's page (pipelines/suffix_benchmark_report.py): per fold the way is chosen
on validation, never on test, and its test figure is the one reported; the published figures are
means over their folds; a log counts as at or above the best published only when the chosen
way's mean is."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

SPEC = importlib.util.spec_from_file_location(
    "suffix_benchmark_report",
    Path(__file__).resolve().parents[1] / "pipelines" / "suffix_benchmark_report.py",
)
report = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(report)


def _fold(unit: Path, val: dict[str, float], test: dict[str, float]) -> None:
    for split, figures in (("val", val), ("test", test)):
        (unit / split).mkdir(parents=True)
        pooled = {"prefixes": 10, "true_at_cap": 0.0}
        pooled |= {w: {"dl_similarity": v, "at_cap": 0.5} for w, v in figures.items()}
        metrics = {"suffix_pooled": pooled}
        (unit / split / "metrics.json").write_text(json.dumps(metrics), encoding="utf-8")


def test_the_way_is_chosen_on_validation(tmp_path: Path) -> None:
    # fold 0: mbr best on val, argmax best on test; fold 1: beam best on val
    _fold(
        tmp_path / "L" / "fold0",
        {"argmax": 0.1, "beam": 0.2, "mbr": 0.3},
        {"argmax": 0.9, "beam": 0.2, "mbr": 0.4},
    )
    _fold(
        tmp_path / "L" / "fold1",
        {"argmax": 0.1, "beam": 0.5, "mbr": 0.3},
        {"argmax": 0.9, "beam": 0.6, "mbr": 0.4},
    )
    published = tmp_path / "published.csv"
    published.write_text(
        ",approach,accuracy,fold,log\n0,Tax,0.2,0,l\n1,Tax,0.4,1,l\n2,DOGE,0.49,0,l\n3,DOGE,0.51,1,l\n",
        encoding="utf-8",
    )  # fmt: skip
    text = report.page(tmp_path, ["L"], report.published(published), "make ...")
    row = next(line for line in text.splitlines() if line.startswith("| L |"))
    assert "**50.00 ± 14.14**" in row  # (0.4 + 0.6) / 2: mbr's test in fold 0, beam's in fold 1
    assert "30.00" in row and "50.00 (DOGE)" in row  # Tax's and the best published means
    assert "at or above the best published approach: 1 of 1 logs" in text
    assert "| L | fold0 | MBR |" in text and "| L | fold1 | beam |" in text


def test_an_unfinished_fold_is_left_out(tmp_path: Path) -> None:
    _fold(tmp_path / "L" / "fold0", {"mbr": 0.3}, {"mbr": 0.4})
    (tmp_path / "L" / "fold1" / "val").mkdir(parents=True)  # its test not written yet
    text = report.page(tmp_path, ["L"], {}, "make ...")
    row = next(line for line in text.splitlines() if line.startswith("| L |"))
    assert row.startswith("| L | 1 |") and "**40.00 ± 0.00**" in row


def test_the_model_reading_attributes_competes_on_validation(tmp_path: Path) -> None:
    plain, inputs = tmp_path / "plain", tmp_path / "inputs"
    _fold(plain / "L" / "fold0", {"argmax": 0.1, "mbr": 0.3}, {"argmax": 0.2, "mbr": 0.4})
    _fold(inputs / "L" / "fold0", {"argmax": 0.2, "mbr": 0.5}, {"argmax": 0.3, "mbr": 0.7})
    _fold(plain / "L" / "fold1", {"argmax": 0.1, "mbr": 0.6}, {"argmax": 0.2, "mbr": 0.5})
    _fold(inputs / "L" / "fold1", {"argmax": 0.2, "mbr": 0.5}, {"argmax": 0.3, "mbr": 0.9})
    _fold(plain / "L" / "fold2", {"mbr": 0.6}, {"mbr": 0.5})  # the inputs' fold 2 not run
    text = report.page(plain, ["L"], {}, "make ...", inputs)
    row = next(line for line in text.splitlines() if line.startswith("| L |"))
    assert row.startswith("| L | 2 |")  # fold 2 waits for its other variant
    assert "**60.00 ± 14.14**" in row  # (0.7 + 0.5) / 2: inputs' mbr in fold 0, plain's in 1
    assert "| L | fold0 | MBR, attributes read |" in text and "| L | fold1 | MBR |" in text
