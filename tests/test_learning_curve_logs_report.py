"""pipelines/learning_curve_logs_report.py on fabricated runs: each variant's mean ± sd per share,
the data worth read off the reference's curve (linear on log share, with its bounds), and the
goal counted per log."""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

REPORT = Path(__file__).resolve().parents[1] / "pipelines" / "learning_curve_logs_report.py"
SHARES = (1, 3, 10, 30, 100)


def _module():
    spec = importlib.util.spec_from_file_location("learning_curve_logs_report", REPORT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def unit(out: Path, log: str, share: float, seed: int, accs: dict[str, float], lam=0.1) -> None:
    """One (log, share, seed) as the pipeline leaves it; `accs`: the four variants' accuracy
    (fractions) by name."""
    base = out / log / f"p{share:g}" / f"s{seed}"
    (base / "exact").mkdir(parents=True)
    train = {
        "cases": {"train": max(1, round(30 * share)), "val": 70, "test": 90},
        "best": {"epoch": 5, "val_accuracy": 0.5},
        "lambda": {"value": lam, "source": "validation", "candidates": []},
    }
    (base / "exact" / "metrics.json").write_text(json.dumps(train))
    for folder, plain, rules in (
        ("eval-none", accs["none"], accs["none, rules"]),
        ("eval-exact", accs["exact"], accs["exact, rules"]),
    ):
        (base / folder).mkdir()
        metrics = {"accuracy": {"accuracy": plain, "accuracy_rules": rules, "changed_by_rules": 1}}
        (base / folder / "metrics.json").write_text(json.dumps(metrics))
    (base / "times.tsv").write_text("12.5\t11.0\t0.5\ttleaf train-task\n")


def test_data_worth_is_read_off_the_reference_curve_on_a_log_scale_of_shares() -> None:
    report = _module()
    reference = [50.0, 60.0, 70.0, 80.0, 90.0]
    # 75 lies halfway between 10 % (70) and 30 % (80): the reference needs sqrt(10 * 30) %
    worth = report.data_worth(SHARES, reference, 75.0, 10)
    assert worth.bound == "="
    assert worth.videos == pytest.approx(math.sqrt(300))
    assert worth.ratio == pytest.approx(math.sqrt(300) / 10)  # 1.73×, not the linear 2.0×
    # above every point of the reference: a lower bound, the largest share over its own
    above = report.data_worth(SHARES, reference, 95.0, 3)
    assert (above.bound, above.ratio) == (">", pytest.approx(100 / 3))
    # at or below the reference's first point: an upper bound
    below = report.data_worth(SHARES, reference, 49.0, 10)
    assert (below.bound, below.ratio) == ("≤", pytest.approx(0.1))
    # worse than the reference at its own share: worth less than 1
    worse = report.data_worth(SHARES, reference, 65.0, 10)
    assert worse.bound == "=" and worse.ratio == pytest.approx(math.sqrt(30) / 10)


def test_the_page_has_means_sds_the_best_variants_worth_and_the_goal(tmp_path: Path) -> None:
    # log A: the rules under argmax worth much at 3 %: its 70 % is the reference's at 10 %
    reference = {1: 0.50, 3: 0.60, 10: 0.70, 30: 0.80, 100: 0.90}
    for share in SHARES:
        for seed in range(3):
            ref = reference[share] + 0.01 * (seed - 1)  # sd 1 point around the mean
            rules = 0.70 + 0.01 * (seed - 1) if share == 3 else ref
            a = {"none": ref, "none, rules": rules, "exact": ref - 0.01, "exact, rules": ref}
            unit(tmp_path, "A", share, seed, a)
            # log B: the knowledge never helps
            b = {"none": ref, "none, rules": ref - 0.02, "exact": ref - 0.01}
            unit(tmp_path, "B", share, seed, b | {"exact, rules": ref - 0.01})
    page = tmp_path / "page" / "curve.md"
    done = subprocess.run(
        [sys.executable, str(REPORT), str(tmp_path), "-o", str(page), "--logs", "A B",
         "--command", "make -f pipelines/learning_curve_logs.mk DATA=PATH"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    text = page.read_text()
    record = json.loads(page.with_suffix(".json").read_text())
    a = {p["share"]: p for p in record["curves"]["A"]["points"]}
    assert a[3]["variants"]["none"]["mean"] == pytest.approx(60.0)
    assert a[3]["variants"]["none"]["sd"] == pytest.approx(1.0)
    assert a[3]["best"] == "none, rules"
    assert a[3]["variants"]["none, rules"]["delta_mean"] == pytest.approx(10.0)
    assert a[3]["variants"]["none, rules"]["above"] == 3
    # the reference reaches 70 % at 10 %: the rules at 3 % are worth 10 / 3 of the data
    assert a[3]["variants"]["none, rules"]["worth"]["ratio"] == pytest.approx(10 / 3)
    assert "| 3 % | 90 | 3 | 60.00 ± 1.00 | 70.00 ± 1.00 |" in text
    assert "| none, rules | +10.00 ± 0.00 | 3/3 | 3.33× |" in text
    goal = record["goal"]
    assert goal["per_log"]["A"]["met"] and not goal["per_log"]["B"]["met"]
    assert goal["logs_met"] == 1 and not goal["met"]
    assert "- A: at most 3.33× at ≤ 10 % (none, rules, 3 %): met" in text
    assert "on at least 2 of 2 logs: **not met** (1 of 2)" in text
    assert "Command: `make -f pipelines/learning_curve_logs.mk DATA=PATH`" in text


def test_unfinished_units_are_left_out_and_no_unit_at_all_exits_2(tmp_path: Path) -> None:
    report = _module()
    accs = {"none": 0.5, "none, rules": 0.5, "exact": 0.5, "exact, rules": 0.5}
    unit(tmp_path, "A", 10, 0, accs)
    unit(tmp_path, "A", 10, 1, accs)
    (tmp_path / "A" / "p10" / "s1" / "eval-exact" / "metrics.json").unlink()  # still running
    rows = report.read_units(tmp_path, "A")
    assert [(r["share"], r["seed"]) for r in rows] == [(10.0, 0)]
    assert rows[0]["seconds"] == pytest.approx(12.5)
    assert report.main([str(tmp_path), "--logs", "C"]) == 2


def test_the_pessimistic_worth_takes_one_standard_error_off_the_paired_gain() -> None:
    report = _module()
    reference = {1: 50.0, 3: 60.0, 10: 70.0, 30: 80.0, 100: 90.0}
    rows = []
    for share, ref in reference.items():
        for seed, gain in ((0, 5.0), (1, 15.0)):  # Δ 10 ± 7.07: s.e. 5
            rules = ref + gain if share == 10 else ref
            names = {"none": ref, "none, rules": rules, "exact": ref, "exact, rules": ref}
            rows.append({"share": float(share), "seed": seed, "train_cases": 3 * share,
                         "lambda": 0.0, "seconds": None, **names})  # fmt: skip
    at = {p["share"]: p for p in report.curve(rows)["points"]}[10.0]
    v = at["variants"]["none, rules"]
    assert at["best"] == "none, rules"
    assert (v["delta_mean"], v["delta_sd"]) == (pytest.approx(10.0), pytest.approx(50**0.5))
    assert v["worth"]["ratio"] == pytest.approx(3.0)  # 80 %: the reference's at 30 %
    assert v["worth_low"]["ratio"] == pytest.approx(math.sqrt(300) / 10)  # 75 %: halfway
