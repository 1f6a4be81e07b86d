"""`tleaf eval action-recognition`: compare logic losses against the reference, as in Fig. 4B.

Each run directory (from `train-task action-recognition`) holds its test figures. A run with a
logic loss is paired with the reference run (`none`) of the same model and seed — both started
from the same weights and saw the same batches — and the relative change in accuracy is

    Δ = (accuracy_with_loss − accuracy_reference) / accuracy_reference   (in %),

the paper's measure. The report gives every run, every pair, a summary per (model, loss) — mean
Δ, how many of the pairs improved, the per-epoch time ratio against the reference — as
report.json and report.md, and boxplots of Δ per model and loss (report.png, like Fig. 4B).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tleaf_cli.data.artifacts import check_writable, write_text_atomic
from tleaf_cli.errors import InputError
from tleaf_cli.tasks.figures import pyplot, save_png

LOSS_ORDER = ("tleaf", "exact", "checker")
MEASURES = ("action_accuracy", "ingredient_accuracy", "pair_accuracy")


def read_run(run_dir: Path) -> dict:
    """One run's settings and test figures; InputError when it is not a finished run."""
    try:
        config = json.loads((run_dir / "config.json").read_text())
        metrics = json.loads((run_dir / "metrics.json").read_text())
    except (OSError, ValueError) as e:
        raise InputError(f"{run_dir}: not a finished train-task run ({e})") from None
    if config.get("kind") != "action-recognizer":
        raise InputError(
            f"{run_dir}: a '{config.get('kind')}' directory, expected a train-task run"
        )
    s, test = config["settings"], metrics["test"]
    return {
        "run": str(run_dir),
        "model": s["model"],
        "logic_loss": s["logic_loss"],
        "formula_from": s["formula_from"],
        "lambda": s["lam"],
        "seed": s["seed"],
        "data": config.get("data", "unknown"),
        **{m: test[m] for m in MEASURES},
        "violation_fraction": test["violation_fraction"],
        "mean_epoch_seconds": metrics["mean_epoch_seconds"],
        "epochs": len(metrics["history"]),
        "best_epoch": metrics["best"]["epoch"],
    }


def pair_with_references(runs: Sequence[dict]) -> list[dict]:
    """For every run with a logic loss, its relative changes against the same-seed reference."""
    refs = {(r["model"], r["seed"]): r for r in runs if r["logic_loss"] == "none"}
    pairs = []
    for r in runs:
        ref = refs.get((r["model"], r["seed"]))
        if r["logic_loss"] == "none" or ref is None:
            continue
        pair = {k: r[k] for k in ("run", "model", "logic_loss", "seed")}
        pair["reference"] = ref["run"]
        for m in MEASURES:
            pair[f"{m}_change_pct"] = 100 * (r[m] - ref[m]) / max(ref[m], 1e-12)
        pair["violation_change"] = r["violation_fraction"] - ref["violation_fraction"]
        pair["epoch_time_ratio"] = r["mean_epoch_seconds"] / max(ref["mean_epoch_seconds"], 1e-12)
        pairs.append(pair)
    return pairs


def summarise(runs: Sequence[dict], pairs: Sequence[dict]) -> list[dict]:
    """Per (model, loss): mean accuracy and violations over runs; mean Δ and wins over pairs."""
    out = []
    keys = sorted({(r["model"], r["logic_loss"]) for r in runs}, key=_order)
    for model, loss in keys:
        group = [r for r in runs if (r["model"], r["logic_loss"]) == (model, loss)]
        row = {"model": model, "logic_loss": loss, "runs": len(group)}
        for m in (*MEASURES, "violation_fraction", "mean_epoch_seconds"):
            row[m] = float(np.mean([r[m] for r in group]))
        mine = [p for p in pairs if (p["model"], p["logic_loss"]) == (model, loss)]
        if mine:
            changes = np.array([p["action_accuracy_change_pct"] for p in mine])
            row["pairs"] = len(mine)
            row["action_change_pct_mean"] = float(changes.mean())
            row["action_change_pct_min"] = float(changes.min())
            row["action_improved"] = int((changes > 0).sum())
            row["ingredient_change_pct_mean"] = float(
                np.mean([p["ingredient_accuracy_change_pct"] for p in mine])
            )
            row["epoch_time_ratio"] = float(np.mean([p["epoch_time_ratio"] for p in mine]))
        out.append(row)
    return out


def _order(key: tuple[str, str]) -> tuple:
    model, loss = key
    return (model, -1 if loss == "none" else LOSS_ORDER.index(loss) if loss in LOSS_ORDER else 9)


def _pct(v: float) -> str:
    return f"{100 * v:.2f}%"


def markdown(runs: Sequence[dict], summary: Sequence[dict]) -> str:
    data = sorted({r["data"] for r in runs})
    lines = [
        "# Action recognition: logic losses against the reference",
        "",
        f"Data: {'; '.join(data)}. {len(runs)} runs. Δ = relative change of test accuracy "
        "against the reference run (no logic loss) of the same model and seed. The checker loss "
        "has no gradient, so its runs train exactly like the reference.",
        "",
        "| model | loss | runs | action acc | ingredient acc | pair acc | violations | "
        "Δ action (mean) | improved | Δ ingredient | time / epoch vs none |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in summary:
        if "pairs" in s:
            delta = (
                f"{s['action_change_pct_mean']:+.2f}% | {s['action_improved']}/{s['pairs']} | "
                f"{s['ingredient_change_pct_mean']:+.2f}% | {s['epoch_time_ratio']:.2f}×"
            )
        else:
            delta = "– | – | – | –"
        lines.append(
            f"| {s['model']} | {s['logic_loss']} | {s['runs']} | {_pct(s['action_accuracy'])} | "
            f"{_pct(s['ingredient_accuracy'])} | {_pct(s['pair_accuracy'])} | "
            f"{_pct(s['violation_fraction'])} | {delta} |"
        )
    lines += [
        "",
        "## Runs",
        "",
        "| run | model | loss | seed | action | ingredient | pair | violations | s/epoch | "
        "best epoch |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in sorted(runs, key=lambda r: (*_order((r["model"], r["logic_loss"])), r["seed"])):
        lines.append(
            f"| {r['run']} | {r['model']} | {r['logic_loss']} | {r['seed']} | "
            f"{100 * r['action_accuracy']:.2f} | {100 * r['ingredient_accuracy']:.2f} | "
            f"{100 * r['pair_accuracy']:.2f} | {100 * r['violation_fraction']:.2f} | "
            f"{r['mean_epoch_seconds']:.2f} | {r['best_epoch']}/{r['epochs']} |"
        )
    return "\n".join(lines) + "\n"


def boxplots(pairs: Sequence[dict], path: Path) -> None:
    """Δ action and Δ ingredient accuracy per model and loss (Fig. 4B's layout), as PNG."""
    plt = pyplot()

    models = sorted({p["model"] for p in pairs}) or ["(no pairs)"]
    fig, axes = plt.subplots(
        2, len(models), figsize=(3.2 * len(models) + 1, 6), squeeze=False, sharey="row"
    )
    for col, model in enumerate(models):
        for row, measure in enumerate(("action_accuracy", "ingredient_accuracy")):
            ax = axes[row][col]
            losses = [
                x for x in LOSS_ORDER if any(p["model"] == model and p["logic_loss"] == x
                                             for p in pairs)
            ]  # fmt: skip
            values = [
                [p[f"{measure}_change_pct"] for p in pairs
                 if p["model"] == model and p["logic_loss"] == x]
                for x in losses
            ]  # fmt: skip
            if values:
                ax.boxplot(values, tick_labels=losses)
            ax.axhline(0.0, color="grey", linewidth=0.8, linestyle="--")
            ax.set_title(f"{model.upper()}: {measure.split('_')[0]}")
            if col == 0:
                ax.set_ylabel("relative change vs reference (%)")
    fig.suptitle("Logic losses vs reference, same seeds (synthetic data)")
    fig.tight_layout()
    save_png(fig, path)


def evaluate_runs(run_dirs: Sequence[str | Path], out_dir: str | Path) -> dict:
    """Read the runs, pair them, write report.json, report.md and report.png; return the report."""
    out_dir = Path(out_dir)
    check_writable(out_dir / "report.json")
    if not run_dirs:
        raise InputError("give at least one train-task run directory")
    runs = [read_run(Path(d)) for d in run_dirs]
    pairs = pair_with_references(runs)
    summary = summarise(runs, pairs)
    report = {"runs": runs, "pairs": pairs, "summary": summary}
    write_text_atomic(out_dir / "report.json", json.dumps(report, indent=2))
    write_text_atomic(out_dir / "report.md", markdown(runs, summary))
    boxplots(pairs, out_dir / "report.png")
    return report
