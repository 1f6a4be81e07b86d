"""Action recognition: the target models, the SMALL pipeline end to end, the eval report."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from tests.conftest import make_small, shared_small, tiny_activities, with_actions
from tleaf_cli.tasks.action_recognition.models import ActionRecognizer


@pytest.mark.parametrize("backbone", ["lstm", "tcn"])
def test_padding_does_not_change_a_videos_outputs(backbone: str) -> None:
    """A video's logits are the same alone and padded beside a longer one."""
    torch.manual_seed(0)
    h = ActionRecognizer(backbone, 6, 4, 3, hidden=8, head_hidden=5).eval()
    short, long = torch.randn(1, 3, 6), torch.randn(1, 7, 6)
    alone_a, alone_i = h(short, torch.tensor([3]))
    padded = torch.cat([torch.nn.functional.pad(short, (0, 0, 0, 4)), long])
    both_a, both_i = h(padded, torch.tensor([3, 7]))
    assert alone_a.shape == (1, 3, 4) and alone_i.shape == (1, 3, 3)
    assert torch.allclose(both_a[0, :3], alone_a[0], atol=1e-5)
    assert torch.allclose(both_i[0, :3], alone_i[0], atol=1e-5)


@pytest.fixture(scope="session")
def small_pipeline(tmp_path_factory) -> Path:
    """pipelines/action_recognition.mk SMALL=1 for the LSTM, with none, tleaf and checker, once
    a run (its tests may run on different xdist workers; they read it, and write elsewhere)."""
    return shared_small(
        tmp_path_factory, "action_recognition.mk", "MODELS=lstm", "LOSSES=none tleaf checker"
    )


@pytest.mark.slow
def test_small_pipeline_end_to_end(small_pipeline: Path) -> None:
    report = json.loads((small_pipeline / "report/report.json").read_text())
    assert {(r["model"], r["logic_loss"]) for r in report["runs"]} == {
        ("lstm", "none"),
        ("lstm", "tleaf"),
        ("lstm", "checker"),
    }
    assert all(r["data"].startswith("synthetic") for r in report["runs"])
    for r in report["runs"]:
        for key in ("action_accuracy", "ingredient_accuracy", "pair_accuracy"):
            assert 0.0 <= r[key] <= 1.0
        assert 0.0 <= r["violation_fraction"] <= 1.0
    # every run's test videos were also decoded under the rules: no violation left
    assert {(d["model"], d["logic_loss"]) for d in report["decodings"]} == {
        ("lstm", "none"), ("lstm", "tleaf"), ("lstm", "checker")
    }  # fmt: skip
    assert all(d["constrained_violation_fraction"] == 0.0 for d in report["decodings"])
    runs = small_pipeline / "runs"
    tleaf = json.loads((runs / "lstm-tleaf-seed0/metrics.json").read_text())
    assert any(h["logic_loss"] > 0 for h in tleaf["history"])  # the loss saw rule sets
    none = json.loads((runs / "lstm-none-seed0/metrics.json").read_text())
    assert all(h["logic_loss"] == 0 for h in none["history"])
    saved = torch.load(runs / "lstm-none-seed0/weights.pt", weights_only=True)
    assert any(k.startswith("action_out") for k in saved)


@pytest.mark.slow
def test_a_finished_pipeline_is_up_to_date(small_pipeline: Path) -> None:
    """`make -q` exits 0: nothing re-runs (the KB and the videos come from one command)."""
    result = make_small("action_recognition.mk", small_pipeline, "-q", "MODELS=lstm",
                        "LOSSES=none tleaf checker")  # fmt: skip
    assert result.returncode == 0, result.stdout[-2000:]


@pytest.mark.slow
def test_checker_loss_trains_exactly_like_the_reference(small_pipeline: Path) -> None:
    """No gradient, same seed: the checker run's weights equal the reference run's."""
    runs = small_pipeline / "runs"
    ref = torch.load(runs / "lstm-none-seed0/weights.pt", weights_only=True)
    checker = torch.load(runs / "lstm-checker-seed0/weights.pt", weights_only=True)
    assert all(torch.equal(ref[k], checker[k]) for k in ref)
    history = json.loads((runs / "lstm-checker-seed0/metrics.json").read_text())["history"]
    assert any(h["logic_loss"] > 0 for h in history)  # it did count violations


@pytest.mark.slow
def test_report_pairs_runs_with_their_reference(small_pipeline: Path) -> None:
    report = json.loads((small_pipeline / "report/report.json").read_text())
    by_loss = {p["logic_loss"]: p for p in report["pairs"]}
    assert set(by_loss) == {"tleaf", "checker"}
    runs = {r["logic_loss"]: r for r in report["runs"]}
    ref, tleaf = runs["none"]["action_accuracy"], runs["tleaf"]["action_accuracy"]
    want = 100 * (tleaf - ref) / ref
    assert by_loss["tleaf"]["action_accuracy_change_pct"] == pytest.approx(want)
    assert by_loss["checker"]["action_accuracy_change_pct"] == 0.0
    assert by_loss["tleaf"]["reference"].endswith("lstm-none-seed0")
    table = (small_pipeline / "report/report.md").read_text()
    assert "| lstm | tleaf | 1 |" in table and "synthetic" in table
    png = (small_pipeline / "report/report.png").read_bytes()
    assert png.startswith(b"\x89PNG")


@pytest.mark.slow
def test_bad_options_and_runs_exit_2(chain_cli, tmp_path: Path, small_pipeline: Path) -> None:
    act, kb = small_pipeline / "activities.parquet", small_pipeline / "kb.ltl"
    args = ("train-task", "action-recognition", act, "--kb", kb, "-o", tmp_path / "r")
    result = chain_cli(*args, "--logic-loss", "tleaf")
    assert result.exit_code == 2 and "--embedder" in result.output
    result = chain_cli(*args, "--model", "gru")
    assert result.exit_code == 2 and "--model" in result.output
    assert "'gru' is not one of" in result.output  # typer lists the choices
    result = chain_cli("eval", "action-recognition", tmp_path, "-o", tmp_path / "rep")
    assert result.exit_code == 2 and "not a finished train-task run" in result.output


@pytest.mark.slow
def test_lambda_defaults_to_what_the_embedder_recommends(
    chain_cli, tmp_path: Path, small_pipeline: Path
) -> None:
    """Without --lambda, the tleaf loss takes the λ its q's folder recommends (train-meta wrote
    it), the exact loss 1; the run's config.json records the λ used."""
    act, kb, q = (small_pipeline / n for n in ("activities.parquet", "kb.ltl", "meta"))
    recommended = json.loads((q / "config.json").read_text())["recommended_lambda"]
    for loss, want in (("tleaf", recommended), ("exact", 1.0)):
        out = tmp_path / loss
        args = ["--logic-loss", loss, "--epochs", "1", "--hidden", "8", "-o", out, "-q"]
        result = chain_cli("train-task", "action-recognition", act, "--kb", kb,
                           *(["--embedder", q] if loss == "tleaf" else []), *args)  # fmt: skip
        assert result.exit_code == 0, result.output
        assert json.loads((out / "config.json").read_text())["settings"]["lam"] == want


def _train(data: Path, kb: Path, out: Path, **settings) -> dict:
    from tleaf_cli.tasks.action_recognition.train import TaskSettings, train_action_recognition

    base = {"logic_loss": "exact", "lam": 1.0, "hidden": 8, "head_hidden": 4, "epochs": 2}
    metrics = train_action_recognition(data, kb, None, out, TaskSettings(**{**base, **settings}))
    return {"metrics": metrics, "weights": torch.load(out / "weights.pt", weights_only=True)}


def _unlabelled_relabelled(data: Path, out: Path) -> Path:
    """A copy of `data` with every unlabelled step relabelled to one other (valid) pair."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(data)
    unlabelled = pa.compute.equal(table["split"], "unlabelled").to_pylist()
    first = table["action"][0].as_py()
    actions = [
        first if u else a for u, a in zip(unlabelled, table["action"].to_pylist(), strict=True)
    ]
    return with_actions(data, actions, out)


def test_unlabelled_videos_teach_only_through_the_logic_loss_and_their_labels_are_unread(
    tmp_path: Path,
) -> None:
    data, kb = tiny_activities(tmp_path, unlabelled=8)
    relabelled = _unlabelled_relabelled(data, tmp_path / "relabelled.parquet")

    used = _train(data, kb, tmp_path / "used", formula_from="labels")
    same = _train(relabelled, kb, tmp_path / "same", formula_from="labels")
    unused = _train(data, kb, tmp_path / "unused", formula_from="labels", unlabelled=False)
    for key, value in used["weights"].items():
        assert torch.equal(value, same["weights"][key])  # their labels are never read
    assert any(not torch.equal(v, unused["weights"][k]) for k, v in used["weights"].items())
    logic = [h["logic_loss"] for h in used["metrics"]["history"]]
    assert logic != [h["logic_loss"] for h in unused["metrics"]["history"]]

    # The reference never reads them: the same run on the file without them.
    ref = _train(data, kb, tmp_path / "ref", logic_loss="none")
    ref_plain = _train(relabelled, kb, tmp_path / "ref2", logic_loss="none", unlabelled=False)
    for key, value in ref["weights"].items():
        assert torch.equal(value, ref_plain["weights"][key])


def test_rule_sets_per_ingredient_change_the_gradient_losses_only(tmp_path: Path) -> None:
    data, kb = tiny_activities(tmp_path)
    whole = _train(data, kb, tmp_path / "whole", formula_from="labels")
    parts = _train(data, kb, tmp_path / "parts", formula_from="labels", rule_sets="ingredient")
    assert all(h["logic_loss"] > 0 for h in parts["metrics"]["history"])
    assert [h["logic_loss"] for h in whole["metrics"]["history"]] != [
        h["logic_loss"] for h in parts["metrics"]["history"]
    ]
    checker = [_train(data, kb, tmp_path / f"c{k}", logic_loss="checker", formula_from="labels",
                      rule_sets=k)
               for k in ("video", "ingredient")]  # fmt: skip
    for key, value in checker[0]["weights"].items():
        assert torch.equal(value, checker[1]["weights"][key])
    assert checker[0]["metrics"]["history"] == [
        {**h, "seconds": checker[0]["metrics"]["history"][n]["seconds"]}
        for n, h in enumerate(checker[1]["metrics"]["history"])
    ]  # the checker always checks the whole rule set: the same loss values


@pytest.mark.slow
def test_a_run_folder_records_portable_paths_and_reads_the_same_when_moved(
    small_pipeline: Path, tmp_path: Path
) -> None:
    """Inputs absolute, the embedder absolute and relative to the run; a run tree copied
    elsewhere gives the same report."""
    import shutil

    from tleaf_cli.tasks.action_recognition.evaluate import read_run

    run = small_pipeline / "runs/lstm-tleaf-seed0"
    config = json.loads((run / "config.json").read_text())
    assert all(Path(i["path"]).is_absolute() and Path(i["path"]).exists() for i in config["inputs"])
    assert Path(config["embedder"]).is_absolute()
    assert (run / config["embedder_relative"]).resolve() == (small_pipeline / "meta").resolve()
    moved = tmp_path / "elsewhere"
    shutil.copytree(small_pipeline, moved)
    copied = moved / "runs/lstm-tleaf-seed0"
    assert (copied / config["embedder_relative"] / "config.json").exists()
    want, got = read_run(run), read_run(copied)
    assert {k: v for k, v in got.items() if k != "run"} == {
        k: v for k, v in want.items() if k != "run"
    }


@pytest.mark.slow
def test_demo_rules_and_traces_steps_run(tmp_path: Path) -> None:
    """The README's main job (pipelines/demo.mk), its first two steps: rules shown, traces
    checked (the model step is the action-recognition chain tested above)."""
    import subprocess
    import sys

    tleaf = Path(sys.executable).parent / "tleaf"
    root = Path(__file__).parent.parent
    result = subprocess.run(
        ["make", "-f", "pipelines/demo.mk", f"TLEAF={tleaf}", f"OUT={tmp_path}", "rules", "traces"],
        cwd=root, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    assert "rinse_before_cook" in result.stdout and "label" in result.stdout
    assert (tmp_path / "graphs").is_dir() and (tmp_path / "traces.parquet").exists()


def test_rules_from_the_whole_knowledge_base_read_no_label_and_no_prediction(
    tmp_path: Path,
) -> None:
    """--formula-from kb: every video, labelled or not, gets the guarded knowledge base; the
    unlabelled videos still teach, their labels unread, and --unlabelled-videos 0 is the run
    without them. A warm-up changes the run; metrics record the unlabelled videos read."""
    data, kb = tiny_activities(tmp_path, unlabelled=8)
    kb_run = _train(data, kb, tmp_path / "kb", formula_from="kb")
    assert all(h["logic_loss"] > 0 for h in kb_run["metrics"]["history"])
    assert kb_run["metrics"]["unlabelled_videos"] == 8
    labels = _train(data, kb, tmp_path / "labels", formula_from="labels")
    assert any(not torch.equal(v, labels["weights"][k]) for k, v in kb_run["weights"].items())

    relabelled = _unlabelled_relabelled(data, tmp_path / "relabelled.parquet")
    same = _train(relabelled, kb, tmp_path / "same", formula_from="kb")
    assert all(torch.equal(v, same["weights"][k]) for k, v in kb_run["weights"].items())

    none_read = _train(data, kb, tmp_path / "zero", formula_from="kb", unlabelled_videos=0)
    off = _train(data, kb, tmp_path / "off", formula_from="kb", unlabelled=False)
    assert none_read["metrics"]["unlabelled_videos"] == 0
    assert all(torch.equal(v, off["weights"][k]) for k, v in none_read["weights"].items())
    some = _train(data, kb, tmp_path / "some", formula_from="kb", unlabelled_videos=3)
    assert some["metrics"]["unlabelled_videos"] == 3
    warm = _train(data, kb, tmp_path / "warm", formula_from="kb", unlabelled_warmup=4)
    assert any(not torch.equal(v, kb_run["weights"][k]) for k, v in warm["weights"].items())
    # the warm-up weighs the first epochs' unlabelled loss down: a lower logic loss reported
    first = [run["metrics"]["history"][0]["logic_loss"] for run in (warm, kb_run)]
    assert first[0] < first[1]


def test_self_training_reads_unlabelled_videos_without_a_logic_loss(tmp_path: Path) -> None:
    """--unlabelled-loss decoded / argmax: unlabelled videos trained on h's own labels for them
    (their own labels unread), with no logic loss; both move h."""
    data, kb = tiny_activities(tmp_path, unlabelled=8)
    ref = _train(data, kb, tmp_path / "ref", logic_loss="none")
    assert ref["metrics"]["unlabelled_videos"] == 0
    runs = {}
    for how in ("decoded", "argmax"):
        runs[how] = _train(data, kb, tmp_path / how, logic_loss="none", unlabelled_loss=how)
        history = runs[how]["metrics"]["history"]
        assert runs[how]["metrics"]["unlabelled_videos"] == 8
        assert all(h["logic_loss"] == 0 and h["unlabelled_loss"] > 0 for h in history)
        assert any(not torch.equal(v, ref["weights"][k]) for k, v in runs[how]["weights"].items())
    relabelled = _unlabelled_relabelled(data, tmp_path / "relabelled.parquet")
    same = _train(relabelled, kb, tmp_path / "same", logic_loss="none", unlabelled_loss="decoded")
    assert all(torch.equal(v, same["weights"][k]) for k, v in runs["decoded"]["weights"].items())
