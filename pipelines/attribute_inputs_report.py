"""The page of pipelines/attribute_inputs.mk: next-activity accuracy on each log's XES, without
and with its attributes read (`--inputs`, `--numeric-inputs`), per fold the run chosen on val.

    python pipelines/attribute_inputs_report.py OUT -o PAGE.md --logs "Helpdesk ..."
        [--published DIR] [--settings '...']
    python pipelines/attribute_inputs_report.py --choose OUT/<log>/fold<k>
    python pipelines/attribute_inputs_report.py --flags OUT/<log>/fold<k>/<none|inputs>

OUT: the pipeline's folder (<log>/fold<k>/{none,inputs,knowledge}/metrics.json, their
evaluations in eval-<run>/); DIR: the peers' published figures (accuracy_raw_results.csv).
--choose: the fold's run chosen on validation (`none` or `inputs`, the higher val accuracy; ties:
none). --flags: the train-task flags that rebuild a run's model, its attributes included.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from event_logs_report import mean_sd, published_accuracy, times_of
from next_activity_models_report import choose as choose_between
from next_activity_models_report import flags as model_flags

VARIANTS = ("none", "inputs")  # without the attributes, reading them


def read(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def choose(fold: Path) -> str:
    """The fold's run with the higher val accuracy (ties: without the attributes)."""
    return choose_between(fold, VARIANTS)


def flags(run: Path) -> str:
    """train-task flags for a run's model, its grid's choice and the attributes it reads."""
    settings = json.loads((run / "config.json").read_text())["settings"]
    out = [model_flags(run)]
    for name in ("inputs", "numeric_inputs"):
        if settings.get(name):
            out.append(f"--{name.replace('_', '-')} {settings[name]}")
    return " ".join(out)


def fold_figures(fold: Path) -> dict | None:
    """A fold's val and test accuracy of each variant, the chosen settings, and which one val
    chooses (ties: without); None until both are evaluated."""
    out = {}
    for v in VARIANTS:
        run, evaluated = read(fold / v / "metrics.json"), read(fold / f"eval-{v}" / "metrics.json")
        if run is None or evaluated is None:
            return None
        config = read(fold / v / "config.json") or {}
        settings = config.get("settings", {})
        out[v] = {
            "val": run["best"]["val_accuracy"],
            "test": evaluated["accuracy"]["accuracy"],
            "model": f"{settings.get('model')} {settings.get('hidden')}×{settings.get('layers')}",
            "inputs": ",".join(
                x for x in (settings.get("inputs"), settings.get("numeric_inputs")) if x
            ),
            "seconds": times_of(fold / v).get("wall_seconds", 0.0),
        }
    out["chosen"] = choose(fold)
    knowledge = read(fold / "eval-knowledge" / "metrics.json")
    run = read(fold / "knowledge" / "metrics.json")
    if knowledge is not None and run is not None:
        out["knowledge"] = {
            "loss": knowledge["accuracy"]["accuracy"],
            "test": knowledge["accuracy"].get("accuracy_rules", knowledge["accuracy"]["accuracy"]),
            "lambda": run.get("lambda", {}).get("value"),
        }
    return out


def matched(folder: Path) -> str:
    """How many of the log's cases pipelines/rm_case_ids.py matched (so kept their attributes),
    from its cases artifact's provenance; all where it read the XES's own ids."""
    import pyarrow.parquet as pq

    path = folder / "cases.parquet"
    if not path.is_file():
        return "—"
    meta = pq.read_schema(path).metadata or {}
    params = json.loads(meta.get(b"tleaf.params", b"{}"))
    if "matched" not in params:
        return "all (the log's own ids)"
    return f"{params['matched']:,} of {params['csv']:,}"


def table(out: Path, logs: list[str], peers: dict) -> tuple[list[str], list[str], list[str]]:
    """The accuracy table, the choices table and the count lines."""
    rows = [
        "| log | folds | without attributes | with attributes | **chosen on val** (folds "
        "with) | folds with attributes above / equal / below without | chosen + exact loss "
        "(λ per fold) | the same, under mined rules | its folds above / equal / below the "
        "chosen | Tax et al. | best published |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    choices = [
        "| log | attributes read | cases read with them (matched to the CSV's ids) | model "
        "chosen per fold (without / with attributes) |",
        "|---|---|---|---|",
    ]
    over_best = over_tax = measured = 0
    for log in logs:
        folds = sorted((out / log).glob("fold*"))
        figures = [f for f in (fold_figures(p) for p in folds) if f is not None]
        if not figures:
            continue
        none = [f["none"]["test"] for f in figures]
        inputs = [f["inputs"]["test"] for f in figures]
        chosen = [f[f["chosen"]]["test"] for f in figures]
        above = sum(i > n for i, n in zip(inputs, none, strict=True))
        equal = sum(i == n for i, n in zip(inputs, none, strict=True))
        known = [f for f in figures if "knowledge" in f]
        rules = [f["knowledge"]["test"] for f in known]
        base = [f[f["chosen"]]["test"] for f in known]
        up = sum(r > b for r, b in zip(rules, base, strict=True))
        same = sum(r == b for r, b in zip(rules, base, strict=True))
        lams = ", ".join(f"{f['knowledge']['lambda']:g}" for f in known)
        loss_cell = f"{mean_sd([f['knowledge']['loss'] for f in known])} ({lams})" if known else "—"
        rules_cell = mean_sd(rules) if known else "—"
        moved = f"{up} / {same} / {len(known) - up - same}" if known else "—"
        mine = peers.get(log.lower(), {})
        tax = mine.get("Tax")
        best = max(mine.items(), key=lambda kv: kv[1]) if mine else None
        mean = 100 * statistics.mean(chosen)
        if mine:
            measured += 1
            over_best += best is not None and mean >= best[1]
            over_tax += tax is not None and mean >= tax
        rows.append(
            f"| {log} | {len(figures)} | {mean_sd(none)} | {mean_sd(inputs)} | "
            f"**{mean_sd(chosen)}** ({sum(f['chosen'] == 'inputs' for f in figures)}) | "
            f"{above} / {equal} / {len(figures) - above - equal} | {loss_cell} | "
            f"{rules_cell} | {moved} | "
            f"{f'{tax:.2f}' if tax is not None else '—'} | "
            f"{f'{best[1]:.2f} ({best[0]})' if best else '—'} |"
        )
        models = "; ".join(f"{f['none']['model']} / {f['inputs']['model']}" for f in figures)
        choices.append(
            f"| {log} | {figures[0]['inputs']['inputs']} | {matched(out / log)} | {models} |"
        )
    counts = []
    if measured:
        counts = [
            f"- chosen on val at or above the best published approach: {over_best} of "
            f"{measured} logs; at or above Tax et al.: {over_tax} of {measured}.",
        ]
    return rows, choices, counts


def cost(out: Path, logs: list[str]) -> str:
    """Per log, its trainings (without, with the attributes, the knowledge: every grid
    candidate and λ) as pipelines/timed-tleaf measured them: wall seconds summed, CPU."""
    parts = []
    for log in logs:
        times = [
            times_of(fold / run)
            for fold in sorted((out / log).glob("fold*"))
            for run in (*VARIANTS, "knowledge")
        ]
        wall = sum(t.get("wall_seconds", 0.0) for t in times) / 60
        cpu = sum(t.get("cpu_seconds", 0.0) for t in times) / 60
        parts.append(f"{log} {wall:.0f} min ({cpu:.0f} CPU min)")
    return "; ".join(parts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?")
    parser.add_argument("-o", "--page", type=Path)
    parser.add_argument("--logs", default="")
    parser.add_argument("--published", type=Path)
    parser.add_argument("--settings", default="")
    parser.add_argument("--choose", type=Path, help="a fold's folder")
    parser.add_argument("--flags", type=Path, help="a run's folder")
    args = parser.parse_args()
    if args.choose is not None:
        print(choose(args.choose))
        return
    if args.flags is not None:
        print(flags(args.flags))
        return
    if args.out is None or args.page is None:
        parser.error("OUT and -o PAGE are needed to write the page")
    logs = args.logs.split()
    settings = re.sub(r"\s{2,}", " ", args.settings)
    rows, choices, counts = table(args.out, logs, published_accuracy(args.published))
    text = "\n".join(
        [
            "# Results: what a log's attributes are worth to next-activity prediction",
            "",
            "Measured by `make -f pipelines/attribute_inputs.mk DATA=PATH "
            "PAGE=docs/results/attribute_inputs.md -j2` (settings: "
            f"`{settings}`) on 2 CPU cores shared with other runs, "
            "one thread per training. Trainings per log (wall seconds summed over the runs, two "
            f"at a time, and CPU): {cost(args.out, logs)}.",
            "",
            "Real logs, each log's own XES (DATA/xes/) with its cases renamed to Rama-Maneiro "
            "et al.'s case ids (pipelines/rm_case_ids.py), so the folds are their benchmark's, "
            "case for case: 5-fold cross-validation, accuracy pooled over every prefix, the end "
            "a target; means ± sd over the folds, %. Without and with attributes: the same "
            "folds, grid (LSTM and Transformer, chosen on val) and seed; chosen on val: per fold "
            "the one of the two with the higher val accuracy; on top of it, the exact loss with "
            "rules mined on the fold's training cases (λ chosen on val, 0 among the candidates) "
            "and prediction under those rules.",
            "",
            *rows,
            "",
            *counts,
            "",
            *choices,
            "",
        ]
    )
    args.page.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.page.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(args.page)
    print(f"{args.page}: written")


if __name__ == "__main__":
    main()
