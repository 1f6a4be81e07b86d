"""`tleaf eval action-recognition`: compare logic losses against the reference, as in Fig. 4B.

Each run directory (from `train-task action-recognition`) holds its test figures. A run with a
logic loss is paired with the reference run (`none`) of the same model and seed — both started
from the same weights and saw the same batches — and the relative change in accuracy is

    Δ = (accuracy_with_loss − accuracy_reference) / accuracy_reference   (in %),

the paper's measure. The report gives every run, every pair, a summary per (model, loss) — mean
Δ, how many of the pairs improved, the per-epoch time ratio against the reference — as
report.json and report.md, and boxplots of Δ per model and loss (report.png, like Fig. 4B).
A tleaf run whose q could read none of the knowledge base's rules trained without a logic loss;
it is refused, not listed as a tleaf run.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tleaf_cli.data.artifacts import check_writable, write_text_atomic
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.action_recognition import DECODINGS, ReportSettings
from tleaf_cli.tasks.figures import pyplot, save_png

LOSS_ORDER = ("tleaf", "exact", "checker")
MEASURES = ("action_accuracy", "ingredient_accuracy", "pair_accuracy")


def read_run(run_dir: Path, decode: str = ReportSettings.decode) -> dict:
    """One run's settings and test figures — argmax decoding's, or constrained decoding's
    (`decode`) — and, where the run has both, both under `decodings`; InputError when it is not
    a finished run or lacks the figures asked for."""
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
    if s["logic_loss"] == "tleaf" and _read_no_rule(metrics.get("rule_sets", {})):
        raise InputError(
            f"{run_dir}: its q could read none of the knowledge base's rules, so its tleaf loss "
            "was 0 throughout and it trained without one; leave it out, or train it again with "
            "a q trained on this knowledge base's rules"
        )
    constrained = test.get("constrained")
    if decode == "constrained":
        if constrained is None:
            raise InputError(
                f"{run_dir}: no constrained-decoding figures (trained with argmax decoding only)"
            )
        figures = constrained
    else:
        figures = test
    row = {
        "run": str(run_dir),
        "model": s["model"],
        "logic_loss": s["logic_loss"],
        "formula_from": s["formula_from"],
        "lambda": s["lam"],
        "seed": s["seed"],
        "data": config.get("data", "unknown"),
        "decode": decode,
        **{m: figures[m] for m in MEASURES},
        "violation_fraction": figures["violation_fraction"],
        "mean_epoch_seconds": metrics["mean_epoch_seconds"],
        "epochs": len(metrics["history"]),
        "best_epoch": metrics["best"]["epoch"],
        "kb_rules_unknown_to_q": metrics.get("rule_sets", {}).get("kb_rules_unknown_to_q", 0),
    }
    if constrained is not None:
        keep = (*MEASURES, "violation_fraction")
        row["decodings"] = {
            "argmax": {m: test[m] for m in keep},
            "constrained": {
                **{m: constrained[m] for m in keep},
                "decode_seconds_per_video": constrained["decode_seconds_per_video"],
            },
        }
    return row


def _read_no_rule(rule_sets: dict) -> bool:
    """Whether a tleaf run's loss compiled no rule because its q knew none of their atoms
    (runs written before training refused such a q)."""
    if "kb_rules" in rule_sets:
        return (
            rule_sets["kb_rules"] > 0
            and rule_sets["kb_rules_unknown_to_q"] == rule_sets["kb_rules"]
        )
    return rule_sets.get("compiled", 1) == 0 and rule_sets.get("rules_left_out_unknown_to_q", 0) > 0


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


def decodings(runs: Sequence[dict]) -> list[dict]:
    """Per (model, loss), over its runs that have both decodings: mean action accuracy and
    violations with argmax and with constrained decoding, the mean relative change of action
    accuracy (constrained against argmax, same run), and the decoding time per video."""
    out = []
    both = [r for r in runs if "decodings" in r]
    for model, loss in sorted({(r["model"], r["logic_loss"]) for r in both}, key=_order):
        group = [r["decodings"] for r in both if (r["model"], r["logic_loss"]) == (model, loss)]
        row = {"model": model, "logic_loss": loss, "runs": len(group)}
        for kind in ("argmax", "constrained"):
            for m in ("action_accuracy", "violation_fraction"):
                row[f"{kind}_{m}"] = float(np.mean([g[kind][m] for g in group]))
        changes = [
            100
            * (g["constrained"]["action_accuracy"] - g["argmax"]["action_accuracy"])
            / max(g["argmax"]["action_accuracy"], 1e-12)
            for g in group
        ]
        row["action_change_pct_mean"] = float(np.mean(changes))
        row["action_improved"] = int(sum(c > 0 for c in changes))
        row["decode_ms_per_video"] = 1000 * float(
            np.mean([g["constrained"]["decode_seconds_per_video"] for g in group])
        )
        out.append(row)
    return out


def markdown(runs: Sequence[dict], summary: Sequence[dict], by_decoding: Sequence[dict]) -> str:
    data = sorted({r["data"] for r in runs})
    decode = runs[0]["decode"] if runs else "argmax"
    lines = [
        "# Action recognition: logic losses against the reference",
        "",
        f"Data: {'; '.join(data)}. {len(runs)} runs, test figures of {decode} decoding. Δ = "
        "relative change of test accuracy against the reference run (no logic loss) of the same "
        "model and seed. The checker loss has no gradient, so its runs train exactly like the "
        "reference.",
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
    if by_decoding:
        lines += [
            "",
            "## Argmax against constrained decoding",
            "",
            "The same runs' test videos decoded both ways; constrained: the most probable pair "
            "sequence the knowledge base's rules accept (rules chosen from the outputs, never the "
            "labels; docs/decoding.md). Δ = relative change of action accuracy, same run.",
            "",
            "| model | loss | runs | action acc argmax | action acc constrained | Δ action | "
            "improved | violations argmax | violations constrained | decoding ms / video |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for d in by_decoding:
            lines.append(
                f"| {d['model']} | {d['logic_loss']} | {d['runs']} | "
                f"{_pct(d['argmax_action_accuracy'])} | {_pct(d['constrained_action_accuracy'])} | "
                f"{d['action_change_pct_mean']:+.2f}% | {d['action_improved']}/{d['runs']} | "
                f"{_pct(d['argmax_violation_fraction'])} | "
                f"{_pct(d['constrained_violation_fraction'])} | {d['decode_ms_per_video']:.1f} |"
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


def boxplots(pairs: Sequence[dict], path: Path, by_decoding: Sequence[dict] = ()) -> None:
    """Δ action and Δ ingredient accuracy per model and loss (Fig. 4B's layout), as PNG; with
    `by_decoding` (`decodings`), a third row: the share of test videos that break a rule, with
    argmax and with constrained decoding, per loss."""
    plt = pyplot()

    models = sorted({p["model"] for p in pairs} | {d["model"] for d in by_decoding})
    models = models or ["(no pairs)"]
    rows = 3 if by_decoding else 2
    fig, axes = plt.subplots(
        rows, len(models), figsize=(max(3.2 * len(models) + 1, 5.5), 3 * rows), squeeze=False,
        sharey="row",
    )  # fmt: skip
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
        if by_decoding:
            ax = axes[2][col]
            mine = [d for d in by_decoding if d["model"] == model]
            at = np.arange(len(mine))
            for shift, kind in ((-0.2, "argmax"), (0.2, "constrained")):
                values = [100 * d[f"{kind}_violation_fraction"] for d in mine]
                ax.bar(at + shift, values, width=0.4, label=kind)
            ax.set_xticks(at, [d["logic_loss"] for d in mine])
            ax.set_ylim(0, 100)
            ax.set_title(f"{model.upper()}: videos breaking a rule")
            if col == 0:
                ax.set_ylabel("% of test videos")
                ax.legend(title="decoding", fontsize="small")
    fig.suptitle("Logic losses vs reference, same seeds (synthetic data)")
    fig.tight_layout()
    save_png(fig, path)


def evaluate_runs(
    run_dirs: Sequence[str | Path], out_dir: str | Path, decode: str = ReportSettings.decode
) -> dict:
    """Read the runs, pair them, write report.json, report.md and report.png; return the report.

    `decode`: whose test figures the main table reads (argmax or constrained decoding)."""
    if decode not in DECODINGS:
        raise SettingError("decode", f"must be one of {', '.join(DECODINGS)}, not '{decode}'")
    out_dir = Path(out_dir)
    check_writable(out_dir / "report.json")
    if not run_dirs:
        raise InputError("give at least one train-task run directory")
    runs = [read_run(Path(d), decode) for d in run_dirs]
    pairs = pair_with_references(runs)
    summary = summarise(runs, pairs)
    by_decoding = decodings(runs)
    report = {"runs": runs, "pairs": pairs, "summary": summary, "decodings": by_decoding}
    write_text_atomic(out_dir / "report.json", json.dumps(report, indent=2))
    write_text_atomic(out_dir / "report.md", markdown(runs, summary, by_decoding))
    boxplots(pairs, out_dir / "report.png", by_decoding)
    return report
