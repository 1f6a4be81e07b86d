"""The learning curve: training on the first N videos, the data-worth reading of the reference's
curve, the λ choice on val, the summary of fake run folders, and the SMALL pipeline."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import torch

from tests.conftest import make_small, tiny_activities, with_actions
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.tasks.action_recognition.learning_curve import (
    Worth,
    choose_lambda,
    data_worth,
    learning_curve,
    reference_videos,
)

SIZES = [10, 20, 40, 80]
REFERENCE = [0.30, 0.40, 0.50, 0.60]


def test_the_reference_is_read_linearly_on_log_videos() -> None:
    # halfway between 20 and 40 in accuracy is their geometric mean in videos
    at = reference_videos(SIZES, REFERENCE, 0.45)
    assert at.bound == "=" and at.videos == pytest.approx(math.sqrt(20 * 40))
    worth = data_worth(SIZES, REFERENCE, 0.45, 10)
    assert worth.ratio == pytest.approx(math.sqrt(800) / 10) and worth.text() == "2.83×"
    # on a point of the curve: that size exactly
    assert data_worth(SIZES, REFERENCE, 0.50, 20).ratio == pytest.approx(2.0)
    # a quarter of the way from 40 to 80 in accuracy: 40 * 2 ** 0.25 videos
    assert reference_videos(SIZES, REFERENCE, 0.525).videos == pytest.approx(40 * 2**0.25)


def test_beyond_the_curve_the_worth_is_a_bound() -> None:
    above = data_worth(SIZES, REFERENCE, 0.65, 10)
    assert (above.bound, above.ratio, above.videos) == (">", 8.0, 80.0)
    assert above.text() == "> 8×"
    below = data_worth(SIZES, REFERENCE, 0.25, 20)  # worse than the reference's first point
    assert (below.bound, below.ratio) == ("≤", 0.5)
    assert Worth(**{"ratio": 0.5, "bound": "≤", "videos": 10.0}).text() == "≤ 0.5×"


def test_a_curve_that_dips_is_read_at_its_first_crossing() -> None:
    sizes, curve = [10, 20, 40, 80], [0.30, 0.50, 0.40, 0.60]
    at = reference_videos(sizes, curve, 0.45)  # crossed between 10 and 20, again after 40
    assert at.videos == pytest.approx(10 * 2**0.75)


def test_the_curve_needs_increasing_sizes() -> None:
    with pytest.raises(InputError, match="increase"):
        reference_videos([20, 10], [0.3, 0.4], 0.35)
    with pytest.raises(InputError):
        reference_videos([10, 20], [0.3], 0.35)


def _row(lam: float, seed: int, val: float, videos: int = 10) -> dict:
    return {"run": f"r{lam}-{seed}", "model": "lstm", "method": "exact", "lambda": lam,
            "seed": seed, "train_videos": videos, "val_action_accuracy": val}  # fmt: skip


def test_lambda_is_chosen_on_mean_val_accuracy_ties_to_the_smaller() -> None:
    runs = [_row(0.3, 0, 0.50), _row(0.3, 1, 0.60), _row(1, 0, 0.56), _row(1, 1, 0.56)]
    runs += [_row(3, 0, 0.30), _row(3, 1, 0.70)]  # the best seed, not the best mean
    choice = choose_lambda(runs)
    assert choice["lambda"] == 1 and [v["lambda"] for v in choice["val"]] == [0.3, 1, 3]
    assert choice["val"][1]["val_action_accuracy"] == pytest.approx(0.56)
    tie = [_row(0.3, 0, 0.25), _row(0.3, 1, 0.75), _row(1, 0, 0.5), _row(1, 1, 0.5)]
    assert choose_lambda(tie)["lambda"] == 0.3
    assert choose_lambda(list(reversed(tie)))["lambda"] == 0.3


def test_lambda_choice_refuses_runs_that_differ_in_more_than_lambda_and_seed() -> None:
    with pytest.raises(InputError, match="more than λ"):
        choose_lambda([_row(1, 0, 0.5), _row(3, 0, 0.5, videos=20)])
    with pytest.raises(InputError, match="different seeds"):
        choose_lambda([_row(1, 0, 0.5), _row(3, 1, 0.5)])
    with pytest.raises(InputError, match="twice"):
        choose_lambda([_row(1, 0, 0.5), _row(1, 0, 0.6)])


def _fake_run(root: Path, model: str, loss: str, videos: int, seed: int, argmax: float,
              constrained: float, lam: float | None = None, val: float = 0.5,
              pair: float = 0.3) -> Path:  # fmt: skip
    """A run folder with the figures the summary reads (no weights); `pair`: its pair accuracy
    under either decoding."""
    run = root / f"{model}-{loss}-n{videos}-seed{seed}-lam{lam}"
    run.mkdir(parents=True)
    settings = {"model": model, "logic_loss": loss, "formula_from": "predictions",
                "lam": 1.0 if lam is None else lam, "seed": seed,
                "train_videos": videos}  # fmt: skip
    config = {"kind": "action-recognizer", "settings": settings, "data": "synthetic: fake"}
    figures = {"ingredient_accuracy": 0.5, "pair_accuracy": pair}
    test = {**figures, "action_accuracy": argmax, "violation_fraction": 0.8}
    test["constrained"] = {**figures, "action_accuracy": constrained, "violation_fraction": 0.0,
                           "decode_seconds_per_video": 0.01}  # fmt: skip
    metrics = {"test": test, "mean_epoch_seconds": 0.1, "history": [{}],
               "best": {"epoch": 1, "val_action_accuracy": val},
               "train_videos": videos}  # fmt: skip
    (run / "config.json").write_text(json.dumps(config))
    (run / "metrics.json").write_text(json.dumps(metrics))
    return run


def test_the_summary_of_fake_runs(tmp_path: Path) -> None:
    """Reference 0.30 / 0.40 / 0.50 at 10 / 20 / 40 videos (two seeds each, ± 0.02); exact at
    10 videos reads 0.45 with argmax: +50 % and +12.5 % per seed... its mean 0.45 is the
    reference's at sqrt(20 * 40) videos, worth 2.83x."""
    runs = []
    for n, acc in zip((10, 20, 40), (0.30, 0.40, 0.50), strict=True):
        for seed, shift in ((0, -0.02), (1, 0.02)):
            runs.append(_fake_run(tmp_path / "runs", "lstm", "none", n, seed, acc + shift, acc,
                                  val=0.45))  # fmt: skip
    runs.append(_fake_run(tmp_path / "runs", "lstm", "exact", 10, 0, 0.42, 0.60, lam=1.0))
    runs.append(_fake_run(tmp_path / "runs", "lstm", "exact", 10, 1, 0.48, 0.60, lam=1.0))
    sweep = [_fake_run(tmp_path / "sweep", "lstm", "exact", 10, s, 0.4, 0.4, lam=lam, val=v)
             for s in (0, 1) for lam, v in ((1.0, 0.5), (3.0, 0.4))]  # fmt: skip
    result = learning_curve(runs, tmp_path / "curve", sweep)
    rows = {(r["train_videos"], r["variant"]): r for r in result["curve"]}
    exact = rows[(10, "exact, argmax")]
    assert exact["action_accuracy_mean"] == pytest.approx(0.45)
    assert exact["action_accuracy_se"] == pytest.approx(0.03)  # std 0.0424 / sqrt 2
    gains = [100 * (0.42 - 0.28) / 0.28, 100 * (0.48 - 0.32) / 0.32]
    assert exact["gain_pct"] == pytest.approx(gains) and exact["improved"] == 2
    assert exact["data_worth"]["bound"] == "="
    assert exact["data_worth"]["ratio"] == pytest.approx(math.sqrt(800) / 10)
    rules = rows[(10, "exact, rules")]  # 0.60 > the reference's best 0.50: a lower bound
    assert rules["data_worth"] == {"ratio": 4.0, "bound": ">", "videos": 40.0}
    assert rows[(20, "none, rules")]["gain_pct_mean"] == pytest.approx(
        (100 * (0.40 - 0.38) / 0.38 + 100 * (0.40 - 0.42) / 0.42) / 2
    )
    assert rows[(20, "none, argmax")]["reference"] and "gain_pct" not in rows[(20, "none, argmax")]
    # λ chosen among the sweep's 1 and 3 and the reference runs of its seeds (λ 0)
    assert [v["lambda"] for v in result["lambda_choices"][0]["val"]] == [0.0, 1.0, 3.0]
    assert result["lambda_choices"][0]["lambda"] == 1.0
    md = (tmp_path / "curve/curve.md").read_text()
    assert "| 10 | exact, argmax | 1 | 2 | 45.00 ± 3.00 |" in md and "2.83×" in md
    assert "> 4×" in md and "0: 45.00, **1: 50.00**" in md
    assert (tmp_path / "curve/curve.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((tmp_path / "curve/curve.json").read_text())["data"] == ["synthetic: fake"]


def test_a_curve_in_pair_accuracy(tmp_path: Path) -> None:
    """A recording's step is its action (the graph's node) and its recipe (the ingredient): the
    curve of pair accuracy reads the pairs' figures, not the actions'. The reference: action
    0.50 / 0.60, pair 0.20 / 0.40 at 10 / 40 videos; exact at 10: action 0.45, pair 0.30 — no
    gain in actions, worth sqrt(10 * 40) / 10 = 2x in pairs."""
    runs = [_fake_run(tmp_path, "lstm", "none", n, 0, a, a, pair=p)
            for n, a, p in ((10, 0.5, 0.2), (40, 0.6, 0.4))]  # fmt: skip
    runs.append(_fake_run(tmp_path, "lstm", "exact", 10, 0, 0.45, 0.45, lam=1.0, pair=0.3))
    exact = {}
    for measure in ("action", "pair"):
        result = learning_curve(runs, tmp_path / measure, measure=measure)
        exact[measure] = next(r for r in result["curve"] if r["variant"] == "exact, argmax")
        assert result["measure"] == measure and exact[measure]["measure"] == measure
    assert exact["action"]["action_accuracy_mean"] == pytest.approx(0.45)
    assert exact["action"]["data_worth"]["bound"] == "≤"
    assert exact["pair"]["pair_accuracy_mean"] == pytest.approx(0.30)
    assert "action_accuracy_mean" not in exact["pair"]
    assert exact["pair"]["data_worth"]["ratio"] == pytest.approx(2.0)
    md = (tmp_path / "pair" / "curve.md").read_text()
    assert "Test pair (action and ingredient) accuracy" in md and "| pair acc (%) |" in md
    assert "| 10 | exact, argmax | 1 | 1 | 30.00 ± 0.00 | +50.00 ± 0.00 | 1/1 | 2.00× |" in md
    with pytest.raises(InputError, match="measure"):
        learning_curve(runs, tmp_path / "x", measure="ingredient")


def test_the_summary_needs_a_reference_and_both_decodings(tmp_path: Path) -> None:
    exact = _fake_run(tmp_path, "lstm", "exact", 10, 0, 0.4, 0.5, lam=1.0)
    with pytest.raises(InputError, match="no reference"):
        learning_curve([exact], tmp_path / "out")
    plain = _fake_run(tmp_path, "lstm", "none", 10, 0, 0.4, 0.5)
    metrics = json.loads((plain / "metrics.json").read_text())
    del metrics["test"]["constrained"]
    (plain / "metrics.json").write_text(json.dumps(metrics))
    with pytest.raises(InputError, match="constrained"):
        learning_curve([plain, exact], tmp_path / "out")


def test_the_cli_writes_the_curve_and_the_lambda(chain_cli, tmp_path: Path) -> None:
    cells = (("none", 10, 0.3), ("none", 20, 0.4), ("exact", 10, 0.35))
    runs = [_fake_run(tmp_path / "runs", "tcn", loss, n, 0, acc, acc, lam=1.0)
            for loss, n, acc in cells]  # fmt: skip
    result = chain_cli("eval", "learning-curve", *runs, "-o", tmp_path / "curve", "-q")
    assert result.exit_code == 0, result.output
    assert (
        "| 10 | exact, argmax | 1 | 1 | 35.00 ± 0.00 | +16.67 ± 0.00 | 1/1 | 1.41× |"
        in (tmp_path / "curve/curve.md").read_text()
    )
    sweep = [_fake_run(tmp_path / "sweep", "tcn", "exact", 10, 0, 0.3, 0.3, lam=lam, val=v)
             for lam, v in ((0.3, 0.4), (1.0, 0.45))]  # fmt: skip
    result = chain_cli("eval", "choose-lambda", *sweep, "-o", tmp_path / "lam.txt")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "lam.txt").read_text() == "1\n"
    # the reference of the same model and size counts as λ 0; another size's is refused
    result = chain_cli("eval", "choose-lambda", *sweep, runs[0], "-o", tmp_path / "z.txt")
    assert result.exit_code == 0 and "0: 50.00%" in result.output, result.output
    result = chain_cli("eval", "choose-lambda", sweep[0], runs[1], "-o", tmp_path / "x.txt")
    assert result.exit_code == 2 and "more than λ" in result.output


def test_training_reads_the_first_n_train_videos_only(tmp_path: Path) -> None:
    """A run on 3 videos gives the same weights on a file whose later train videos are
    relabelled; too many videos is a SettingError naming the setting."""
    import pyarrow.parquet as pq

    from tleaf_cli.tasks.action_recognition.train import TaskSettings, train_action_recognition

    data, kb = tiny_activities(tmp_path)
    table = pq.read_table(data)
    ids, splits = table["video_id"].to_pylist(), table["split"].to_pylist()
    first = sorted({v for v, s in zip(ids, splits, strict=True) if s == "train"})[:3]
    other = table["action"][0].as_py()
    labels = table["action"].to_pylist()
    actions = [a if s != "train" or v in first else other
               for v, s, a in zip(ids, splits, labels, strict=True)]  # fmt: skip
    relabelled = with_actions(data, actions, tmp_path / "relabelled.parquet")

    def train(path: Path, out: str, videos: int | None) -> tuple[dict, dict]:
        settings = TaskSettings(hidden=8, head_hidden=4, epochs=2, train_videos=videos)
        metrics = train_action_recognition(path, kb, None, tmp_path / out, settings)
        return metrics, torch.load(tmp_path / out / "weights.pt", weights_only=True)

    three, weights = train(data, "a", 3)
    _, same = train(relabelled, "b", 3)
    _, all_of_them = train(relabelled, "c", None)
    assert three["train_videos"] == 3
    assert all(torch.equal(v, same[k]) for k, v in weights.items())
    assert any(not torch.equal(v, all_of_them[k]) for k, v in weights.items())
    with pytest.raises(SettingError, match="train_videos") as refused:
        train(data, "d", 9)
    assert "has 8 videos" in str(refused.value)


@pytest.mark.slow
def test_small_learning_curve_pipeline(tmp_path: Path) -> None:
    """pipelines/learning_curve.mk SMALL=1: every size, model, loss and seed, and the runs with
    unlabelled videos; λ chosen on val from the sweep, its runs reused; then `make -q` finds
    nothing to do."""
    out = tmp_path / "curve"
    result = make_small("learning_curve.mk", out, "-j2")
    assert result.returncode == 0, result.stderr[-2000:]
    curve = json.loads((out / "curve/curve.json").read_text())
    cells = {(r["model"], r["train_videos"], r["variant"]) for r in curve["curve"]}
    methods = ("none", "exact", "exact (whole KB)", "tleaf")
    variants = {f"{m}, {d}" for m in methods for d in ("argmax", "rules")}
    # and the LSTM at 4 labelled videos with 8 unlabelled ones, trained three ways
    with_unlabelled = {
        f"{m} + 8 unlabelled, {d}"
        for d in ("argmax", "rules")
        for m in ("exact", "exact (whole KB)", "self-training (decoded)")
    }
    assert cells == {(m, n, v) for m, n in (("lstm", 4), ("lstm", 16), ("tcn", 16))
                     for v in variants} | {("lstm", 4, v) for v in with_unlabelled}  # fmt: skip
    read = {r["unlabelled_videos"] for r in curve["runs"] if "unlabelled" in r["method"]}
    assert read == {8}
    assert all(len(r["seeds"]) == 2 for r in curve["curve"])
    assert all(r["data"].startswith("synthetic") for r in curve["runs"])
    assert all(r["decodings"]["constrained"]["violation_fraction"] == 0 for r in curve["runs"])
    for choice in curve["lambda_choices"]:  # exact at 0.5 and 1, one seed; 0: the reference
        assert [v["lambda"] for v in choice["val"]] == [0.0, 0.5, 1.0]
        lam = (out / f"lambda/{choice['model']}-exact-n{choice['train_videos']}.txt").read_text()
        assert float(lam) == choice["lambda"]
        main = out / f"runs/{choice['model']}-exact-n{choice['train_videos']}-seed0/metrics.json"
        swept = out / f"sweep/{choice['model']}-exact-n{choice['train_videos']}-lam{lam.strip()}"
        if choice["lambda"] == 0:  # no sweep run at λ 0: the main run trained at it
            config = json.loads((main.parent / "config.json").read_text())
            assert config["settings"]["lam"] == 0.0
        else:
            assert main.read_text() == (Path(f"{swept}-seed0") / "metrics.json").read_text()
    assert (out / "curve/curve.png").stat().st_size > 0
    assert make_small("learning_curve.mk", out, "-q").returncode == 0
