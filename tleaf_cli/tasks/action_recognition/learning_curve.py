"""`tleaf eval learning-curve` and `tleaf eval choose-lambda`: what the knowledge is worth as the
training set grows (pipelines/learning_curve.mk).

The runs (`train-task action-recognition --train-videos N --decode constrained`) share one data
set: a run at N training videos read the first N of its train split, and every size is scored on
the same val and test videos. A **variant** is a training method with a decoding: the method's
runs decoded by argmax, or under the knowledge base's rules (constrained decoding). A method
(`method`) is a logic loss, where its rule sets come from the whole knowledge base, and the
unlabelled videos it read and what it trained them on. The **reference** is the runs without a
logic loss (and without unlabelled videos) decoded by argmax. Per model, size and variant:

- accuracy — the measure's (`MEASURES`: action by default; pair, where a step is right only
  with its ingredient, e.g. a recording's step and its recipe) — and the share of test videos
  that break a rule, mean ± s.e. over seeds;
- the gain, Δ = (accuracy − reference accuracy) / reference accuracy in %, each run against
  the reference run of the same model, size and seed, mean ± s.e. over seeds;
- what the knowledge is worth in data: the number of training videos the reference needs to
  reach the variant's mean accuracy — read off the reference's curve of mean accuracies,
  linear between sizes on a log scale of videos, its first crossing — divided by the variant's
  own number (`data_worth`). Beyond the largest size it is a lower bound ("> 320/N"), and at
  or below the reference's first point an upper bound ("≤ 10/N").

Writes curve.md (the table), curve.json (every figure, every run) and curve.png (action
accuracy against training videos, log scale, mean ± s.e. per variant, one panel per model).

`choose_lambda` picks a logic loss's λ from runs that differ only in λ and seed: the λ with the
best mean val action accuracy (best epoch), ties to the smaller λ; the reference runs (no logic
loss) count as λ 0, so "no logic loss" is always among the choices.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from tleaf_cli.data.artifacts import check_writable, write_text_atomic
from tleaf_cli.errors import InputError
from tleaf_cli.tasks.action_recognition.evaluate import read_run
from tleaf_cli.tasks.figures import pyplot, save_png
from tleaf_cli.tasks.model_checking_table import mean_se

REFERENCE = ("none", "argmax")
# what a curve can measure: the test accuracy of the action, or of the pair (action and
# ingredient); its rows' keys are `<measure>_accuracy`, `_mean`, `_se`
MEASURES = {"action": "action", "pair": "pair (action and ingredient)"}
LOSS_ORDER = ("none", "exact", "tleaf", "checker")
DECODE_ORDER = ("argmax", "constrained")


@dataclass(frozen=True)
class Worth:
    """Training videos the reference needs to match a variant, over the variant's own.

    `bound`: "=" (read off the reference's curve), ">" (the reference never gets there: the
    largest size over the variant's, a lower bound) or "≤" (the reference's smallest size
    already does: that size over the variant's, an upper bound). `videos`: the reference's
    videos at the match (interpolated), or the bound's size."""

    ratio: float
    bound: str
    videos: float

    def text(self) -> str:
        if self.bound == "=":
            return f"{self.ratio:.2f}×"
        return f"{self.bound} {self.ratio:.3g}×"


def reference_videos(sizes: Sequence[int], accuracies: Sequence[float], target: float) -> Worth:
    """Where the reference's curve (mean accuracy per size, sizes increasing) first reaches
    `target`: linear between neighbouring sizes on log(videos). The Worth's ratio is left at 1
    (`data_worth` sets it)."""
    if len(sizes) != len(accuracies) or not sizes:
        raise InputError("the reference's curve needs one accuracy per size, and a size")
    if any(b <= a for a, b in itertools.pairwise(sizes)):
        raise InputError(f"sizes must increase: {list(sizes)}")
    if accuracies[0] >= target:
        return Worth(1.0, "≤", float(sizes[0]))
    for i in range(1, len(sizes)):
        if accuracies[i] >= target:
            low, high = accuracies[i - 1], accuracies[i]
            share = (target - low) / (high - low)
            log_n = math.log(sizes[i - 1]) + share * (math.log(sizes[i]) - math.log(sizes[i - 1]))
            return Worth(1.0, "=", math.exp(log_n))
    return Worth(1.0, ">", float(sizes[-1]))


def data_worth(
    sizes: Sequence[int], accuracies: Sequence[float], target: float, videos: int
) -> Worth:
    """What a variant trained on `videos` with mean accuracy `target` is worth in data: the
    reference's videos to match it (`reference_videos`) over `videos`."""
    at = reference_videos(sizes, accuracies, target)
    return Worth(at.videos / videos, at.bound, at.videos)


def read_curve_run(run_dir: str | Path, both_decodings: bool = True) -> dict:
    """One finished run: `evaluate.read_run`'s row with its training videos and its best val
    action accuracy; InputError when `both_decodings` and it lacks constrained decoding's."""
    run_dir = Path(run_dir)
    row = read_run(run_dir)
    if both_decodings and "decodings" not in row:
        raise InputError(
            f"{run_dir}: no constrained-decoding figures (trained with argmax decoding only)"
        )
    metrics = json.loads((run_dir / "metrics.json").read_text())
    config = json.loads((run_dir / "config.json").read_text())
    videos = metrics.get("train_videos", config["settings"].get("train_videos"))
    if videos is None:
        raise InputError(f"{run_dir}: its number of training videos is not recorded")
    row["train_videos"] = int(videos)
    row["unlabelled_videos"] = int(metrics.get("unlabelled_videos", 0))
    row["method"] = method(config["settings"], row["unlabelled_videos"])
    row["val_action_accuracy"] = float(metrics["best"]["val_action_accuracy"])
    return row


def choose_lambda(runs: Sequence[dict]) -> dict:
    """The λ with the best mean val action accuracy among runs of one model, loss and size that
    differ only in λ and seed (ties: the smaller λ); InputError when they differ otherwise or
    the λs were not run at the same seeds. Reference runs (no logic loss) of the same model and
    size count as λ 0: where a loss can hurt, "no logic loss" is among the choices (and wins a
    tie)."""
    if not runs:
        raise InputError("give at least one run")
    losses = [r for r in runs if r["method"] != "none"] or runs
    cells = {(r["model"], r["method"], r["train_videos"]) for r in losses}
    cells |= {(r["model"], c[1], r["train_videos"]) for r in runs for c in cells}
    if len(cells) > 1:
        raise InputError(f"the runs differ in more than λ and seed: {sorted(cells)}")
    by_lambda: dict[float, dict[int, float]] = {}
    for r in runs:
        lam = 0.0 if r["method"] == "none" else r["lambda"]
        if lam is None:
            raise InputError(f"{r['run']}: no λ recorded")
        seeds = by_lambda.setdefault(float(lam), {})
        if r["seed"] in seeds:
            raise InputError(f"{r['run']}: λ {lam:g} at seed {r['seed']} twice")
        seeds[r["seed"]] = r["val_action_accuracy"]
    seed_sets = {tuple(sorted(s)) for s in by_lambda.values()}
    if len(seed_sets) > 1:
        raise InputError(f"the λs were run at different seeds: {sorted(seed_sets)}")
    table = [
        {"lambda": lam, "val_action_accuracy": float(np.mean(list(s.values()))), "seeds": len(s)}
        for lam, s in sorted(by_lambda.items())
    ]
    best = max(table, key=lambda row: (row["val_action_accuracy"], -row["lambda"]))
    model, name, videos = cells.pop()
    return {
        "model": model,
        "method": name,
        "train_videos": videos,
        "lambda": best["lambda"],
        "val": table,
    }


def method(settings: dict, unlabelled: int) -> str:
    """A run's training as the curve names it: its logic loss; `(whole KB)` where its rule sets
    are the whole knowledge base (`--formula-from kb`); `+ U unlabelled` where it read U
    unlabelled videos, with what it trained them on unless that is the logic loss."""
    name, how = settings["logic_loss"], settings.get("unlabelled_loss", "logic")
    if settings.get("formula_from") == "kb" and name != "none":
        name += " (whole KB)"
    if unlabelled and how != "logic":  # self-training on them, with the logic loss if any
        name = f"self-training ({how})" if name == "none" else f"{name}, self-training ({how})"
    return f"{name} + {unlabelled} unlabelled" if unlabelled else name


def variant_name(method: str, decode: str) -> str:
    return f"{method}, {'rules' if decode == 'constrained' else 'argmax'}"


def _variant_order(variant: tuple[str, str]) -> tuple:
    name, decode = variant
    loss = name.split(" ")[0]
    return (LOSS_ORDER.index(loss) if loss in LOSS_ORDER else 9, name, DECODE_ORDER.index(decode))


def curve(runs: Sequence[dict], measure: str = "action") -> list[dict]:
    """One row per model, size and variant: the `measure`'s accuracy (`MEASURES`), violations,
    the gain against the same-seed reference (mean ± s.e.), and the data-worth against the
    model's reference curve."""
    if measure not in MEASURES:
        raise InputError(f"no measure {measure!r}: one of {', '.join(MEASURES)}")
    key = f"{measure}_accuracy"
    rows = []
    for model in sorted({r["model"] for r in runs}):
        mine = [r for r in runs if r["model"] == model]
        refs = {
            (r["train_videos"], r["seed"]): r["decodings"]["argmax"][key]
            for r in mine
            if r["method"] == "none"
        }
        ref_sizes = sorted({n for n, _ in refs})
        ref_curve = [float(np.mean([a for (m, _), a in refs.items() if m == n])) for n in ref_sizes]
        variants = sorted(
            {(r["method"], d) for r in mine for d in DECODE_ORDER}, key=_variant_order
        )
        for n in sorted({r["train_videos"] for r in mine}):
            for name, decode in variants:
                group = sorted(
                    (r for r in mine if r["train_videos"] == n and r["method"] == name),
                    key=lambda r: r["seed"],
                )
                if not group:
                    continue
                figures = [r["decodings"][decode] for r in group]
                accuracy = [f[key] for f in figures]
                mean, se = mean_se(accuracy)
                row = {
                    "model": model,
                    "train_videos": n,
                    "method": name,
                    "unlabelled_videos": group[0]["unlabelled_videos"],
                    "decode": decode,
                    "variant": variant_name(name, decode),
                    "reference": (name, decode) == REFERENCE,
                    "lambda": sorted({r["lambda"] for r in group if r["lambda"] is not None}),
                    "seeds": [r["seed"] for r in group],
                    "measure": measure,
                    key: accuracy,
                    f"{key}_mean": mean,
                    f"{key}_se": se,
                    "violation_fraction_mean": float(
                        np.mean([f["violation_fraction"] for f in figures])
                    ),
                }
                gains = [
                    100 * (a - refs[(n, r["seed"])]) / max(refs[(n, r["seed"])], 1e-12)
                    for a, r in zip(accuracy, group, strict=True)
                    if (n, r["seed"]) in refs
                ]
                if gains and not row["reference"]:
                    row["gain_pct"] = gains
                    row["gain_pct_mean"], row["gain_pct_se"] = mean_se(gains)
                    row["improved"] = int(sum(g > 0 for g in gains))
                if ref_sizes:
                    row["data_worth"] = asdict(data_worth(ref_sizes, ref_curve, mean, n))
                rows.append(row)
    return rows


def _pm(mean: float, se: float, scale: float = 100.0, sign: bool = False) -> str:
    return f"{scale * mean:{'+' if sign else ''}.2f} ± {scale * se:.2f}"


def markdown(
    rows: Sequence[dict], choices: Sequence[dict], data: Sequence[str], measure: str = "action"
) -> str:
    """curve.md: per model, a table of mean accuracies per size and variant, then every figure."""
    name = MEASURES[measure]
    lines = [
        "# Action recognition: the learning curve",
        "",
        f"Data: {'; '.join(data)}. Test {name} accuracy (%), mean ± s.e. over seeds, against "
        "the number of training videos (a larger set holds every smaller one; the same val "
        "and test videos at every size). A variant is a training method (a logic loss; '(whole "
        "KB)': its rule sets are the whole knowledge base; '+ U unlabelled': it also read U "
        "unlabelled videos) with a decoding: argmax, or rules (constrained decoding under the "
        "knowledge base's rules). The reference: no logic loss, argmax. Δ: relative change of "
        f"{measure} accuracy against the reference run of the same size and seed, mean ± s.e. "
        "Data worth: the training videos the reference "
        "needs to reach the variant's mean accuracy (its curve of mean accuracies, linear "
        "between sizes on a log scale of videos) over the variant's own; '> x': the reference "
        "never reaches it (x = largest size / videos); '≤ x': its smallest size already does.",
    ]
    for model in sorted({r["model"] for r in rows}):
        lines += _model_tables(model, [r for r in rows if r["model"] == model], measure)
    if choices:
        lines += [
            "",
            "## λ chosen on validation",
            "",
            "Mean best val action accuracy (%) per λ over the sweep's seeds; the chosen λ in bold; "
            "λ 0: the reference runs (no logic loss) of the same seeds.",
            "",
            "| model | loss | videos | seeds | val accuracy per λ |",
            "|---|---|---|---|---|",
        ]
        for c in choices:
            cells = ", ".join(
                (f"**{v['lambda']:g}: {100 * v['val_action_accuracy']:.2f}**"
                 if v["lambda"] == c["lambda"]
                 else f"{v['lambda']:g}: {100 * v['val_action_accuracy']:.2f}")
                for v in c["val"]
            )  # fmt: skip
            lines.append(
                f"| {c['model']} | {c['method']} | {c['train_videos']} | "
                f"{c['val'][0]['seeds']} | {cells} |"
            )
    return "\n".join(lines) + "\n"


def _model_tables(model: str, mine: Sequence[dict], measure: str) -> list[str]:
    """curve.md's tables of one model: mean accuracy per size and variant (the methods without
    unlabelled videos), every such variant against the reference, then the runs that also read
    unlabelled videos, against the same reference."""
    labelled = [r for r in mine if not r["unlabelled_videos"]]
    variants = sorted({(r["method"], r["decode"]) for r in labelled}, key=_variant_order)
    at = {(r["train_videos"], r["method"], r["decode"]): r for r in labelled}
    lines = [
        "",
        f"## {model.upper()}: {measure} accuracy (%)",
        "",
        "| videos | " + " | ".join(variant_name(*v) for v in variants) + " |",
        "|---|" + "---|" * len(variants),
    ]
    for n in sorted({r["train_videos"] for r in labelled}):
        cells = [at.get((n, *v)) for v in variants]
        means = ["–" if r is None else _pm(*_accuracy(r)) for r in cells]
        lines.append(f"| {n} | " + " | ".join(means) + " |")
    by_size = sorted(labelled, key=lambda r: (r["train_videos"], _variant_order(
        (r["method"], r["decode"]))))  # fmt: skip
    lines += ["", f"## {model.upper()}: every variant against the reference", "",
              *_detail_header(measure)]  # fmt: skip
    lines += [_detail(r) for r in by_size]
    unlabelled = sorted(
        (r for r in mine if r["unlabelled_videos"]),
        key=lambda r: (r["train_videos"], _variant_order((r["method"], r["decode"]))),
    )
    if unlabelled:
        lines += [
            "",
            f"## {model.upper()}: unlabelled videos",
            "",
            "Δ and data worth against the reference of the same labelled videos (no logic loss, "
            "no unlabelled videos, argmax), seed by seed.",
            "",
            *_detail_header(measure),
            *(_detail(r) for r in unlabelled),
        ]
    return lines


def _detail_header(measure: str) -> list[str]:
    """The head of the tables against the reference."""
    return [
        f"| videos | variant | λ | seeds | {measure} acc (%) | Δ {measure} (%) | improved | "
        "data worth | violations |",
        "|---|---|---|---|---|---|---|---|---|",
    ]


def _accuracy(row: dict) -> tuple[float, float]:
    """A curve row's mean accuracy and its s.e., in its measure."""
    key = f"{row.get('measure', 'action')}_accuracy"
    return row[f"{key}_mean"], row[f"{key}_se"]


def _detail(r: dict) -> str:
    """One variant at one size: its row of the tables against the reference."""
    if r["reference"]:
        gain = "reference"
    elif "gain_pct_mean" in r:
        gain = _pm(r["gain_pct_mean"], r["gain_pct_se"], 1.0, sign=True)
    else:
        gain = "–"
    improved = f"{r['improved']}/{len(r['gain_pct'])}" if "improved" in r else "–"
    worth = "–" if r["reference"] or "data_worth" not in r else Worth(**r["data_worth"]).text()
    lam = ", ".join(f"{x:g}" for x in r["lambda"]) if r["method"] != "none" else "–"
    return (
        f"| {r['train_videos']} | {r['variant']} | {lam} | {len(r['seeds'])} | "
        f"{_pm(*_accuracy(r))} | {gain} | {improved} | "
        f"{worth} | {100 * r['violation_fraction_mean']:.1f}% |"
    )


def figure(rows: Sequence[dict], path: Path, measure: str = "action") -> None:
    """The `measure`'s accuracy against training videos (log x), mean ± s.e. per variant, one
    panel per model: colour = training method, solid = argmax, dashed = constrained decoding."""
    plt = pyplot()
    models = sorted({r["model"] for r in rows}) or ["(no runs)"]
    fig, axes = plt.subplots(
        1, len(models), figsize=(5.2 * len(models), 4.2), squeeze=False, sharey=True
    )
    drawn = {r["method"] for r in rows if not r["unlabelled_videos"]}
    names = sorted(drawn, key=lambda m: _variant_order((m, "argmax")))
    colours = {name: f"C{k % 10}" for k, name in enumerate(names)}
    for ax, model in zip(axes[0], models, strict=True):
        mine = [r for r in rows if r["model"] == model and not r["unlabelled_videos"]]
        variants = sorted({(r["method"], r["decode"]) for r in mine}, key=_variant_order)
        for k, (name, decode) in enumerate(variants):
            points = sorted(
                (r for r in mine if (r["method"], r["decode"]) == (name, decode)),
                key=lambda r: r["train_videos"],
            )
            shift = 1 + 0.012 * (k - (len(variants) - 1) / 2)  # side by side on the log axis
            ax.errorbar(
                [r["train_videos"] * shift for r in points],
                [100 * _accuracy(r)[0] for r in points],
                yerr=[100 * _accuracy(r)[1] for r in points],
                label=variant_name(name, decode),
                color=colours.get(name, "C9"),
                linestyle="-" if decode == "argmax" else "--",
                marker="o" if decode == "argmax" else "s",
                markersize=4,
                capsize=3,
            )
        ax.set_xscale("log")
        sizes = sorted({r["train_videos"] for r in mine})
        ax.set_xticks(sizes, [str(n) for n in sizes])
        ax.minorticks_off()
        ax.set_xlabel("training videos (log scale)")
        ax.set_title(model.upper())
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(f"test {measure} accuracy (%)")
    axes[0][-1].legend(fontsize="small", title="method, decoding")
    fig.suptitle("Learning curve, mean ± s.e. over seeds")
    fig.tight_layout()
    save_png(fig, path)


def learning_curve(
    run_dirs: Sequence[str | Path],
    out_dir: str | Path,
    sweep_dirs: Sequence[str | Path] = (),
    measure: str = "action",
) -> dict:
    """Read the runs (and the λ sweep's), write curve.json, curve.md and curve.png; return the
    curve. `sweep_dirs`: runs that differ in λ, grouped by model, loss and size, each group's
    choice shown (`choose_lambda`); `measure`: the accuracy the curve and its data worth are in
    (`MEASURES`; λ is chosen on val action accuracy, as the runs kept their best epoch)."""
    out_dir = Path(out_dir)
    for name in ("curve.json", "curve.md", "curve.png"):
        check_writable(out_dir / name)
    if not run_dirs:
        raise InputError("give at least one train-task run directory")
    runs = [read_curve_run(d) for d in run_dirs]
    if not any(r["method"] == "none" for r in runs):
        raise InputError("no reference run (no logic loss) among the runs")
    rows = curve(runs, measure)
    sweep = [read_curve_run(d, both_decodings=False) for d in sweep_dirs]
    choices = [_choice(cell, sweep, runs) for cell in _sweep_cells(sweep)]
    data = sorted({r["data"] for r in runs})
    result = {
        "data": data, "measure": measure, "curve": rows, "lambda_choices": choices, "runs": runs
    }  # fmt: skip
    write_text_atomic(out_dir / "curve.json", json.dumps(result, indent=2))
    write_text_atomic(out_dir / "curve.md", markdown(rows, choices, data, measure))
    figure(rows, out_dir / "curve.png", measure)
    return result


def _sweep_cells(sweep: Sequence[dict]) -> list[tuple[str, str, int]]:
    """The (model, method, size) cells of the sweep's runs with a logic loss."""
    return sorted(
        {(r["model"], r["method"], r["train_videos"]) for r in sweep if r["method"] != "none"}
    )


def _choice(cell: tuple[str, str, int], sweep: Sequence[dict], runs: Sequence[dict]) -> dict:
    """`choose_lambda` of one cell of the sweep, the reference runs (λ 0) of its model and size
    at the sweep's seeds among the choices: from the sweep where it has them, else the curve's
    (left out where they lack one of the sweep's seeds)."""
    model, _, videos = cell
    mine = [r for r in sweep if (r["model"], r["method"], r["train_videos"]) == cell]
    seeds = {r["seed"] for r in mine}

    def references(rows: Sequence[dict]) -> list[dict]:
        return [
            r for r in rows
            if (r["model"], r["method"], r["train_videos"]) == (model, "none", videos)
            and r["seed"] in seeds
        ]  # fmt: skip

    zero = references(sweep) or references(runs)
    if {r["seed"] for r in zero} != seeds:  # not at every seed: no fair λ 0 to show
        zero = []
    return choose_lambda(mine + zero)


def choose_lambda_file(run_dirs: Sequence[str | Path], out: str | Path) -> dict:
    """`choose_lambda` over the runs; writes the chosen λ (as %g prints it) to `out`."""
    check_writable(out)
    if not run_dirs:
        raise InputError("give at least one train-task run directory")
    choice = choose_lambda([read_curve_run(d, both_decodings=False) for d in run_dirs])
    write_text_atomic(out, f"{choice['lambda']:g}\n")
    return choice
