"""Table I both ways: the MLP's per-epoch test record (never used to choose), the report script
of pipelines/table1_protocols.mk, and the pipeline end to end on a tiny set (SMALL=1)."""

from __future__ import annotations

import importlib.util
import itertools
import json
import sys
from pathlib import Path

import pytest
import torch

from tests.conftest import make_small
from tleaf_cli.tasks import model_checking as mc

ROOT = Path(__file__).parent.parent


def _report_module():
    spec = importlib.util.spec_from_file_location(
        "table1_protocols_report", ROOT / "pipelines/table1_protocols_report.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _split(n: int, seed: int) -> mc.Split:
    """Pairs whose label is whether the two vectors' first coordinates share a sign (learnable,
    not linear in the concatenation), with some label noise."""
    g = torch.Generator().manual_seed(seed)
    z_f, z_w = torch.randn(n, 4, generator=g), torch.randn(n, 4, generator=g)
    label = ((z_f[:, 0] * z_w[:, 0]) > 0).float()
    flip = torch.rand(n, generator=g) < 0.1
    label = torch.where(flip, 1 - label, label)
    return mc.Split([f"f{k % 7}" for k in range(n)], z_f, z_w, label, ["uniform"] * n)


def test_the_watched_test_score_never_changes_the_kept_mlp() -> None:
    train, val, test = _split(400, 0), _split(120, 1), _split(120, 2)
    settings = mc.EvalSettings(pair_features="rich", epochs=12, patience=4, seed=3)
    torch.manual_seed(0)  # the MLP's initial weights (evaluate_model_checking seeds them too)
    plain = mc._fit_mlp(train, val, settings, balanced=True)
    history: list[dict] = []
    torch.manual_seed(0)
    watched = mc._fit_mlp(train, val, settings, balanced=True, watch=test, history=history)
    for a, b in zip(plain.state_dict().values(), watched.state_dict().values(), strict=True):
        assert torch.equal(a, b)  # the same epoch kept, the same weights
    assert [e["epoch"] for e in history] == list(range(1, len(history) + 1))
    kept = [e for e in history if e["kept"]]
    assert kept and all(a["val"] < b["val"] for a, b in itertools.pairwise(kept))
    # the kept epoch's recorded test score is the returned model's
    score = mc._scores(mc._predict(watched, test, settings), test)["balanced_accuracy"]
    assert kept[-1]["test_balanced_accuracy"] == pytest.approx(score)
    assert all(0.0 <= e["test_balanced_accuracy"] <= 1.0 for e in history)


def _write_report(
    out: Path, protocol: str, tier: str, seed: int, preset: str, chosen: float, best: float
) -> None:
    folder = out / protocol / tier / f"seed{seed}" / f"eval-{preset}"
    folder.mkdir(parents=True)
    epochs = [
        {"epoch": 1, "val": 0.6, "kept": True, "test_balanced_accuracy": chosen},
        {"epoch": 2, "val": 0.5, "kept": False, "test_balanced_accuracy": best},
    ]
    report = {
        "mlp": {"balanced_accuracy": chosen},
        "mlp_epochs": epochs,
        "mlp_best_test": epochs[1],
        "distance": {"balanced_accuracy": 0.5},
        "settings": {"pair_features": "concat"},
        "test_formulas": 10,
    }
    (folder / "report.json").write_text(json.dumps(report))


def test_the_report_averages_seeds_names_missing_cells_and_judges_the_goal(tmp_path) -> None:
    report = _report_module()
    out = tmp_path / "out"
    _write_report(out, "paper", "low", 0, "paper-code", 0.82, 0.86)
    _write_report(out, "paper", "low", 1, "paper-code", 0.84, 0.88)
    _write_report(out, "paper", "high", 0, "paper-code", 0.50, 0.55)
    _write_report(out, "tleaf", "low", 0, "best", 0.90, 0.91)
    (out / "times.tsv").write_text(
        "12.5\t12\t0.3\ttleaf train-meta a b -o x/paper/low/seed0/meta-paper-code -q\n"
        "Command exited with non-zero status 1\n"
        "2.5\t2\t0.3\ttleaf compile-dfa f -o x/paper/low/dfas.parquet\n"
    )
    text = report.section(out, "N=5", seeds=[0, 1])
    row = next(line for line in text.splitlines() if "`paper-code` | authors'" in line)
    assert "83.00 ± 1.00 (2 seeds)" in row and "50.00 (1 seed)" in row  # (82 + 84) / 2, s.e. 1
    best = next(line for line in text.splitlines() if "| best test |" in line)
    assert "87.00 ± 1.00 (2 seeds)" in best
    assert "low -0.43 (within 2, 2 seeds)" in text and "moderate not run" in text
    assert "high -16.90 (not within 2" in text
    assert "paper-code / paper / low seed 1" not in text  # that cell has both seeds
    assert "paper-code / paper / high seed 1" in text and "best / tleaf / low seed 1" in text
    assert "paper-code / tleaf / moderate seed 0" in text  # every tier of the grid asked for
    assert "| authors' | data and q_e 2 · paper-code 12 + 0 | – | – |" in text
    assert "paper-code / paper / low: 1 / 2 / 2" in text and "N=5" in text

    page = tmp_path / "page.md"
    page.write_text("# Title\n\nbody\n")
    report.write_page(page, text)
    report.write_page(page, text.replace("N=5", "N=6"))  # the second run replaces the first
    written = page.read_text()
    assert written.startswith("# Title\n\n" + report.START)
    assert written.count(report.START) == 1 and "N=6" in written and "N=5" not in written
    assert written.rstrip().endswith("body")


def test_the_ablation_table_has_a_row_per_variant_and_its_own_page_section(tmp_path) -> None:
    report = _report_module()
    out = tmp_path / "out"
    _write_report(out, "paper", "low", 0, "paper-code", 0.67, 0.70)
    base = out / "paper/low/seed0"
    (base / "meta-paper-code").mkdir()
    (base / "meta-paper-code/metrics.json").write_text('{"best": {"heldout_accuracy": 0.6}}')
    for variant, score in (("base", 0.67), ("sphere", 0.81)):
        folder = out / "ablation" / variant / "low"
        folder.mkdir(parents=True)
        (folder / "report.json").write_text(json.dumps({"mlp": {"balanced_accuracy": score}}))
    (out / "times.tsv").write_text(
        "30\t29\t1\ttleaf train-meta a b -o x/ablation/sphere/low/meta -q\n"
        "7\t6\t1\ttleaf gen-traces d -o x/paper/low/traces-hard-negatives.parquet\n"
        "12.5\t12\t0.3\ttleaf train-meta a b -o x/paper/low/seed0/meta-paper-code -q\n"
    )
    text = report.ablation_section(out, ["base", "sphere", "distance"], ["low", "moderate"])
    rows = [line for line in text.splitlines() if line.startswith("| ") and "change" not in line]
    assert len(rows) == 3
    assert rows[0].endswith("| 67.00 (0.60) | – |")  # the grid's cell and its q_m's val score
    assert rows[1].endswith("| 81.00 | – |") and rows[2].endswith("| – | – |")
    assert "Wall time 37 s" in text  # the ablation's calls only
    assert "in all" in report.section(out) and "(12 s in all" in report.section(out)

    page = tmp_path / "page.md"
    page.write_text("# Title\n\nbody\n")
    report.write_page(page, report.section(out))
    report.write_page(page, text, report.ABLATION_START, report.ABLATION_END)
    report.write_page(
        page, text.replace("81.00", "82.00"), report.ABLATION_START, report.ABLATION_END
    )
    written = page.read_text()
    assert written.index(report.END) < written.index(report.ABLATION_START)
    assert written.count(report.ABLATION_START) == 1 and "82.00" in written
    assert written.rstrip().endswith("body")


@pytest.mark.slow
def test_the_table1_protocols_pipeline_runs_both_ways_on_a_tiny_set(tmp_path: Path) -> None:
    out = tmp_path / "t1"
    python = f"PYTHON={sys.executable}"
    result = make_small("table1_protocols.mk", out, python, timeout=900)
    assert result.returncode == 0, result.stderr[-2000:]
    for protocol in ("paper", "tleaf"):
        for preset, features in (("paper-code", "concat"), ("best", "rich")):
            report = json.loads(
                (out / protocol / "low/seed0" / f"eval-{preset}/report.json").read_text()
            )
            assert report["preset"] == preset and report["settings"]["pair_features"] == features
            best = report["mlp_best_test"]["test_balanced_accuracy"]
            assert best >= report["mlp"]["balanced_accuracy"]
    traces = out / "paper/low/traces.parquet"
    import pyarrow.parquet as pq

    assert set(pq.read_table(traces).column("source").to_pylist()) == {"uniform"}
    section = (out / "table1_protocols.md").read_text()
    assert section.count("| `paper-code` |") == 4 and "| paper: DFA (T-LEAF) |" in section
    assert make_small("table1_protocols.mk", out, python, "-q").returncode == 0  # up to date
    # a seed added to a finished grid is run: the report is out of date (make -q exits 1)
    assert make_small("table1_protocols.mk", out, python, "-q", "SEEDS=0 1").returncode == 1
    result = make_small("table1_protocols.mk", out, python, "ablation", timeout=900)
    assert result.returncode == 0, result.stderr[-2000:]
    hard = pq.read_table(out / "paper/low/traces-hard-negatives.parquet").column("source")
    assert "hard" in hard.to_pylist()
    config = json.loads((out / "ablation/optimiser/low/meta/config.json").read_text())
    assert config["settings"]["lr"] == 0.001 and config["settings"]["schedule"] == "cosine"
    assert config["settings"]["encoder"] == "authors"  # the rest of paper-code kept
    section = (out / "table1_protocols.md").read_text()
    rows = section.split("<!-- table1-ablation -->")[1].splitlines()
    assert sum(line.startswith("| ") for line in rows) == 11  # header and 10 variants
    assert not any(line.startswith("| ") and "| – |" in line for line in rows)
