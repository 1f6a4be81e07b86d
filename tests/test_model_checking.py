"""`tleaf eval model-checking`: report files, never a test formula in training."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from tests.conftest import make_small
from tleaf_cli.data.artifacts import read_provenance, write_artifact
from tleaf_cli.embed.train_meta import MetaSettings, train_meta


@pytest.fixture(scope="module")
def meta_model(chain, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("mc") / "meta"
    settings = MetaSettings.preset(
        "paper", hidden=32, layers=2, out_dim=16, epochs=2, batch_size=32
    )
    train_meta(chain["dfas"], chain["traces"], chain["edge"], out, settings)
    return out


def test_report_is_well_formed(chain, chain_cli, meta_model, tmp_path: Path) -> None:
    out = tmp_path / "report"
    result = chain_cli(
        "eval",
        "model-checking",
        chain["dfas"],
        chain["traces"],
        "--embedder",
        meta_model,
        "-o",
        out,
        "--label",
        "tiny",
        "--all-negatives",
    )
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["label"] == "tiny" and report["embedder"] == "dfa" and report["seed"] == 0
    test_ids = {
        r["formula_id"] for r in pq.read_table(chain["traces"]).to_pylist() if r["split"] == "test"
    }
    assert report["test_formulas"] == len(test_ids)
    for clf in ("mlp", "mlp_all_negatives", "distance"):
        assert 0.0 <= report[clf]["accuracy"] <= 1.0
        assert 0.0 <= report[clf]["balanced_accuracy"] <= 1.0
    assert "| MLP 512-128 fitted on all negatives" in (out / "report.md").read_text()


def test_the_second_mlp_is_fitted_only_when_asked(chain, meta_model, tmp_path) -> None:
    from tleaf_cli.tasks import model_checking as mc

    report = mc.evaluate_model_checking(
        meta_model, chain["dfas"], chain["traces"], tmp_path, mc.EvalSettings()
    )
    assert "mlp_all_negatives" not in report and "mlp" in report
    assert "fitted on all negatives" not in (tmp_path / "report.md").read_text()


def test_bfloat16_products_decide_like_float32(chain, meta_model, tmp_path) -> None:
    """precision="bfloat16" changes the MLP's arithmetic, not what it learns: on the tiny
    chain its test accuracy is within a few points of float32's."""
    from tleaf_cli.tasks import model_checking as mc

    exact, fast = (
        mc.evaluate_model_checking(
            meta_model, chain["dfas"], chain["traces"], tmp_path / p, mc.EvalSettings(precision=p)
        )["mlp"]["balanced_accuracy"]
        for p in ("float32", "bfloat16")
    )
    assert abs(exact - fast) <= 0.1


@pytest.mark.parametrize("native", [False, True])
def test_auto_precision_follows_the_hardware(chain, meta_model, tmp_path, monkeypatch, native):
    """precision="auto" is bfloat16 where the hardware has it natively, float32 elsewhere: the
    same MLP, to the bit, as the precision it stands for."""
    from tleaf_cli.tasks import model_checking as mc

    monkeypatch.setattr(mc, "native_bfloat16", lambda device: native)
    auto, named = (
        mc.evaluate_model_checking(
            meta_model, chain["dfas"], chain["traces"], tmp_path / p, mc.EvalSettings(precision=p)
        )["mlp"]
        for p in ("auto", "bfloat16" if native else "float32")
    )
    assert auto == named


def test_the_paper_mlp_is_fitted_on_satisfying_and_uniform_traces_only(
    chain, meta_model, tmp_path, monkeypatch
) -> None:
    from tleaf_cli.tasks import model_checking as mc

    fitted = []
    real = mc._fit_mlp

    def spy(train, val, settings, **kwargs):
        fitted.append((train, val, kwargs.get("balanced", False)))
        return real(train, val, settings, **kwargs)

    monkeypatch.setattr(mc, "_fit_mlp", spy)
    mc.evaluate_model_checking(
        meta_model, chain["dfas"], chain["traces"], tmp_path, mc.EvalSettings(all_negatives=True)
    )
    (paper_train, paper_val, balanced), (all_train, all_val, all_balanced) = fitted
    assert balanced and not all_balanced  # the paper's MLP weighs both classes the same
    for paper, every in ((paper_train, all_train), (paper_val, all_val)):
        kinds = {(bool(y), s) for y, s in zip(every.label, every.source, strict=True)}
        assert (False, "hard") in kinds  # the data has hard negatives ...
        kept = {(bool(y), s) for y, s in zip(paper.label, paper.source, strict=True)}
        assert (False, "hard") not in kept and (False, "uniform") in kept  # ... the paper's MLP not
        assert int(paper.label.sum()) == int(every.label.sum())  # every satisfying trace kept
        uniform = sum(
            s == "uniform" and not y for y, s in zip(every.label, every.source, strict=True)
        )
        assert len(paper.label) == int(every.label.sum()) + uniform


def test_a_formula_in_train_and_test_is_refused(chain, chain_cli, meta_model, tmp_path):
    table = pq.read_table(chain["traces"])
    rows = table.to_pylist()
    leaked = next(r["formula_id"] for r in rows if r["split"] == "test")
    for r in rows:
        if r["formula_id"] == leaked and r["label"]:
            r["split"] = "train"  # half of a test formula's traces now in train
    prov = read_provenance(chain["traces"])
    bad = tmp_path / "leaky.parquet"
    write_artifact(
        type(table).from_pylist(rows, schema=table.schema),
        bad,
        kind=prov.kind,
        schema=prov.schema,
        params=prov.params,
        inputs=prov.inputs,
    )
    result = chain_cli(
        "eval", "model-checking", chain["dfas"], bad, "--embedder", meta_model, "-o", tmp_path / "r"
    )
    assert result.exit_code == 2
    assert "both train and test" in result.output


@pytest.mark.slow
def test_small_pipeline_end_to_end(tmp_path: Path) -> None:
    """pipelines/model_checking.mk SMALL=1: gen-formulas to the results table."""
    result = make_small("model_checking.mk", tmp_path / "mc")
    assert result.returncode == 0, result.stderr[-2000:]
    table = (tmp_path / "mc" / "results.md").read_text()
    for row in ("Syntax tree", "DFA (T-LEAF), preset paper", "DFA (T-LEAF), preset best"):
        assert f"| {row} | MLP 512-128, balanced accuracy | " in table
    assert (tmp_path / "mc" / "tsne-low-seed0.png").read_bytes()[:4] == b"\x89PNG"
    for embedder in ("syntax", "dfa"):
        report = json.loads(
            (tmp_path / "mc/low/seed0" / f"eval-{embedder}/report.json").read_text()
        )
        assert report["embedder"] == embedder and report["label"] == "low"
    # A second make has nothing to do: only what changed is re-run.
    assert make_small("model_checking.mk", tmp_path / "mc", "-q").returncode == 0
    # ...and a seed added to a finished grid is run (make -q exits 1: out of date).
    assert make_small("model_checking.mk", tmp_path / "mc", "-q", "SEEDS=0 1").returncode == 1


def test_tsne_figure_shows_a_test_formula_for_each_embedder(chain, chain_cli, meta_model, tmp_path):
    png = tmp_path / "fig.png"
    args = ["eval", "tsne", chain["dfas"], chain["traces"], "-o", png, "--pairs", 12]
    result = chain_cli(*args, "--embedder", meta_model, "--embedder", meta_model)
    assert result.exit_code == 0, result.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = pq.read_table(chain["traces"]).to_pylist()
    test_ids = {r["formula_id"] for r in rows if r["split"] == "test"}
    train_ids = {r["formula_id"] for r in rows if r["split"] == "train"}
    shown = result.output.split("formula ")[1].split(",")[0]
    assert shown in test_ids and shown not in train_ids
    unknown = chain_cli(*args, "--embedder", meta_model, "--formula", "no-such-id")
    assert unknown.exit_code == 2 and "no-such-id" in unknown.output


def test_results_table_reads_both_mlps_and_older_reports(tmp_path) -> None:
    from tleaf_cli.tasks.model_checking_table import results_table

    def report(seed: int, mlp: float, with_all: bool) -> Path:
        r = {
            "embedder": "dfa",
            "label": "low",
            "mlp": {"accuracy": mlp, "hard_negative_accuracy": 0.5},
            "distance": {"accuracy": 0.6},
        }
        if with_all:  # a current report; the other is one written before balanced accuracy
            r["mlp"]["balanced_accuracy"] = mlp - 0.1
            r["distance"]["balanced_accuracy"] = 0.55
            r["settings"] = {"pair_features": "rich"}
            r["mlp_all_negatives"] = {
                "accuracy": 0.7,
                "balanced_accuracy": 0.65,
                "hard_negative_accuracy": 0.75,
            }
        path = tmp_path / f"r{seed}.json"
        path.write_text(json.dumps(r))
        return path

    table = results_table([report(0, 0.8, True), report(1, 0.9, False)], tmp_path / "t.md")
    lines = table.splitlines()
    cells = [line.strip("| ").split(" | ") for line in lines[2:] if line.startswith("|")]
    rows = {c[1]: c[2] for c in cells}
    # the MLPs' inputs named under the table: the older report's (no settings) was concat
    assert lines[-1] == (
        "The MLPs' input (pair features): concat, [z_φ ; z_w], "
        "rich, [z_φ ; z_w ; abs(z_φ − z_w) ; z_φ ⊙ z_w]."
    )
    assert rows["MLP 512-128, accuracy (2 : 1 satisfying)"] == "85.00 ± 5.00 (n=2)"
    assert rows["MLP 512-128, balanced accuracy"] == "70.00 ± 0.00 (n=1)"  # the older: none
    assert rows["MLP fitted on all negatives, balanced accuracy"] == "65.00 ± 0.00 (n=1)"
    assert rows["MLP fitted on all negatives, hard negatives only"] == "75.00 ± 0.00 (n=1)"
    assert rows["distance rule, balanced accuracy"] == "55.00 ± 0.00 (n=1)"
    assert rows["the paper's (MLP)"] == "83.43 ± 0.73"


def test_the_table_has_a_row_per_preset(tmp_path) -> None:
    """q_m of preset paper and of preset best: two DFA rows, the paper's figures once after them."""
    from tleaf_cli.tasks.model_checking_table import results_table

    paths = []
    for preset, accuracy in (("best", 0.9), ("paper", 0.8)):
        scores = {"accuracy": accuracy, "balanced_accuracy": accuracy, "hard_negative_accuracy": 1}
        r = {"label": "low", "embedder": "dfa", "preset": preset, "mlp": scores, "distance": {}}
        paths.append(tmp_path / f"{preset}.json")
        paths[-1].write_text(json.dumps(r))
    lines = results_table(paths, tmp_path / "t.md").splitlines()
    titles = [line.split(" | ")[0].strip("| ") for line in lines[2:] if line.startswith("| ")]
    assert list(dict.fromkeys(titles)) == [
        "DFA (T-LEAF), preset paper", "DFA (T-LEAF), preset best", "DFA (T-LEAF)"
    ]  # fmt: skip
    balanced = [line for line in lines if "MLP 512-128, balanced accuracy" in line]
    assert "80.00" in balanced[0] and "90.00" in balanced[1]
    assert sum("the paper's (MLP)" in line for line in lines) == 1
    # no report fitted the second MLP (--all-negatives): its rows are left out, not blank
    assert not any("fitted on all negatives" in line for line in lines)


def test_balanced_accuracy_and_class_weights() -> None:
    import numpy as np
    import torch

    from tleaf_cli.tasks.model_checking import _balanced_accuracy, _class_weights

    label = np.array([True] * 20 + [False] * 10)
    assert _balanced_accuracy(np.ones(30, dtype=bool), label) == 0.5  # "always satisfies"
    assert (np.ones(30, dtype=bool) == label).mean() == 2 / 3  # ... which plain accuracy rewards
    pred = label.copy()
    pred[:5] = False  # a quarter of the satisfying ones missed
    assert _balanced_accuracy(pred, label) == (0.75 + 1.0) / 2
    w = _class_weights(torch.tensor(label, dtype=torch.float32))
    assert torch.isclose(w[:20].sum(), w[20:].sum()) and torch.isclose(w.mean(), torch.tensor(1.0))


def test_the_summary_line_gives_balanced_accuracy(chain, chain_cli, meta_model, tmp_path) -> None:
    """The one line a run prints names and gives the balanced accuracy, the figure Table I and
    the docs compare, not the plain accuracy over twice as many satisfying traces."""
    out = tmp_path / "report"
    result = chain_cli(
        "eval", "model-checking", chain["dfas"], chain["traces"], "--embedder", meta_model,
        "-o", out,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    mlp, distance = (100 * report[c]["balanced_accuracy"] for c in ("mlp", "distance"))
    line = " ".join(result.output.split())
    assert f"balanced accuracy MLP {mlp:.2f}%, distance rule {distance:.2f}%" in line, line
