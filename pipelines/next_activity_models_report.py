"""The page of pipelines/next_activity_models.mk (docs/results/next_activity_models.md's form)
from its runs and the peers' published figures; and the pipeline's small steps.

    python pipelines/next_activity_models_report.py [OUT] -o PAGE.md --runs RECORD.json
        [--published DIR] [--logs "<log> ..." --settings "LSTM_GRID=... ..."] [--all "<log> ..."]
    python pipelines/next_activity_models_report.py --choose OUT/<log>/fold<k>
    python pipelines/next_activity_models_report.py --flags OUT/<log>/fold<k>/<model>
    python pipelines/next_activity_models_report.py OUT --say OUT/<log>/fold<k>/<step>

--choose: the fold's best model, chosen on validation only: `lstm` or `transformer`, whichever
grid-chosen run has the higher val accuracy (metrics.json's "best"; ties: lstm). --flags: the
train-task flags that rebuild a grid-chosen run's model (its config.json's "settings": the model
and every field of its grid, with hidden, layers and lr always), for the knowledge run whose λ-0
candidate it is. --say: one line on a finished step.

OUT: the pipeline's folder (<log>/fold<k>/...); without it the page is written from the record
alone. RECORD: the record of runs kept beside the page (JSON: what the page reads of each run,
by its path in OUT, each fold's choice, each log's wall time and the settings it ran with): the
runs of OUT are added to it (replacing the same paths) and the page is written from all of it,
so logs measured by separate invocations on the same code add up to one page. DIR: the peers'
published figures (accuracy_raw_results.csv, looked up by the log's lower-cased name). `--all`:
the pipeline's own logs, those the tally lines name. The page's "What the leaders read" section
is written by hand: a page rewritten keeps it.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from collections import Counter, defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from event_logs_report import mean_sd, published_accuracy, times_of

MODELS = ("lstm", "transformer")  # the grids the best model is chosen among, ties to the first
TRAININGS = ("prefix-table", "lstm", "transformer", "knowledge")
ALWAYS = ("hidden", "layers", "lr")  # settings --flags always names, besides the grid's fields
HAND = "## What the leaders read"
Runs = dict[str, dict]


def val_accuracy(run: Path) -> float:
    return json.loads((run / "metrics.json").read_text())["best"]["val_accuracy"]


def choose(fold: Path, runs: tuple[str, ...] = MODELS) -> str:
    """The fold's run (of `runs`, its folders) with the higher val accuracy (ties: the first:
    of the models, lstm)."""
    return max(runs, key=lambda m: (val_accuracy(fold / m), -runs.index(m)))


def flags(run: Path) -> str:
    """train-task flags for a run's model and the settings its grid chose (the model once, when
    the grid chose it too)."""
    settings = json.loads((run / "config.json").read_text())["settings"]
    fields = [part.split("=")[0] for part in (settings.get("grid") or "").split()]
    out = ["--model", str(settings["model"])]
    for name in dict.fromkeys(f for f in [*fields, *ALWAYS] if f != "model"):
        out += [f"--{name.replace('_', '-')}", str(settings[name])]
    return " ".join(out)


def chosen_settings(settings: dict) -> str:
    """A run's model in words: hidden size × layers, learning rate."""
    return f"{settings['hidden']}×{settings['layers']}, lr {settings['lr']:g}"


def runs_of(out: Path | None) -> Runs:
    """What the page reads of every run under `out`, by its path there: a training's val
    accuracy, test accuracy, grid and λ choices, settings, epochs and seconds (its grid's and
    λ's candidates are in its own metrics); an evaluation's accuracy; a fold's choice."""
    runs: Runs = {}
    if out is None or not out.is_dir():
        return runs
    for path in sorted(out.rglob("best.txt")):
        runs[path.relative_to(out).as_posix()] = {"model": path.read_text().strip()}
    for path in sorted(out.rglob("metrics.json")):
        key = path.relative_to(out).as_posix()
        if "/grid/" in key or "/lambda-choice/" in key:
            continue
        metrics = json.loads(path.read_text())
        if "scored_cases" in metrics:  # eval next-activity
            runs[key] = {"accuracy": metrics["accuracy"]}
        elif path.parent.name in TRAININGS:
            config = json.loads((path.parent / "config.json").read_text())
            runs[key] = {
                "val_accuracy": metrics["best"]["val_accuracy"],
                "test_accuracy": metrics["test"]["accuracy"],
                "epochs": len(metrics["history"]),
                "grid": metrics.get("grid"),
                "lambda": metrics.get("lambda"),
                "settings": {k: config["settings"][k] for k in ("model", *ALWAYS)},
                **times_of(path.parent),
            }
    return runs


def commands_of(out: Path | None) -> dict[str, dict]:
    """Every timed command under `out` (pipelines/timed-tleaf's <folder>.times.tsv, written as
    the command ends), by its path there: when it started and ended (epoch seconds), its wall
    and CPU seconds."""
    commands: dict[str, dict] = {}
    if out is None or not out.is_dir():
        return commands
    for path in sorted(out.rglob("*.times.tsv")):
        timed = times_of(path.parent / path.name.removesuffix(".times.tsv"))
        if not timed:
            continue
        end = path.stat().st_mtime
        commands[path.relative_to(out).as_posix()] = {
            "start": round(end - timed["wall_seconds"], 2),
            "end": round(end, 2),
            "wall": timed["wall_seconds"],
            "cpu": timed["cpu_seconds"],
        }
    return commands


def union_seconds(spans: list[tuple[float, float]]) -> float:
    """The time covered by some of the spans (two commands at once count once)."""
    total, reach = 0.0, float("-inf")
    for start, end in sorted(spans):
        if end > reach:
            total += end - max(start, reach)
            reach = end
    return total


def kept_runs(
    out: Path | None, record: Path | None, logs: list[str], settings: str, pipeline: list[str]
) -> dict:
    """The runs of `out` added to the `record` file (rewritten atomically; without `out`, read
    only): {"runs", "commands": every timed command's span and seconds, "settings": each log's
    invocation settings, "pipeline": the pipeline's logs}."""
    kept: dict = {"runs": {}, "commands": {}, "settings": {}, "pipeline": []}
    if record is not None and record.is_file():
        kept.update(json.loads(record.read_text()))
    for log in logs:
        kept["settings"][log] = settings
    if pipeline:
        kept["pipeline"] = pipeline
    kept["runs"].update(runs_of(out))
    kept["commands"].update(commands_of(out))
    if record is not None and out is not None:
        record.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=record.parent, delete=False) as f:
            json.dump(kept, f, indent=1, sort_keys=True)
            f.write("\n")
        os.chmod(f.name, 0o644)
        os.replace(f.name, record)
    return kept


def logs_of(runs: Runs) -> list[str]:
    return sorted({key.split("/")[0] for key in runs}, key=str.lower)


def folds_of(runs: Runs, log: str) -> list[str]:
    """The log's folds whose every evaluation is in the record, in order."""
    names = sorted({key.split("/")[1] for key in runs if key.startswith(f"{log}/fold")})
    return [
        f"{log}/{name}"
        for name in names
        if all(f"{log}/{name}/eval-{m}/metrics.json" in runs for m in TRAININGS)
        and f"{log}/{name}/best.txt" in runs
    ]


def fold_figures(runs: Runs, fold: str) -> dict:
    """One fold's figures (fractions): each model's test accuracy, the best's, the knowledge
    run's under the rules, the leakage; the best model's name."""
    acc = {m: runs[f"{fold}/eval-{m}/metrics.json"]["accuracy"] for m in TRAININGS}
    best = runs[f"{fold}/best.txt"]["model"]
    return {
        "prefix-table": acc["prefix-table"]["accuracy"],
        "leakage": acc["prefix-table"].get("leakage"),
        "lstm": acc["lstm"]["accuracy"],
        "transformer": acc["transformer"]["accuracy"],
        "best": acc[best]["accuracy"],
        "best_model": best,
        "knowledge": acc["knowledge"]["accuracy"],
        "knowledge_rules": acc["knowledge"].get("accuracy_rules", acc["knowledge"]["accuracy"]),
    }


def percent(values: list[float]) -> str:
    return "—" if not values else f"{100 * statistics.mean(values):.1f}"


def main_table(
    runs: Runs, peers: dict, pipeline: list[str], published: bool
) -> tuple[list[str], list[str]]:
    """The table of 5-fold means and the lines tallying it against the published figures."""
    lines = [
        "| log | folds | prefix table | leakage | LSTM (grid on val) | Transformer (grid on val) "
        "| **best (chosen on val per fold)** | best + exact loss (λ on val), under the mined "
        "rules | folds above / equal / below the best | Tax et al. | best published |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    counted = {log.lower() for log in pipeline} or {log.lower() for log in logs_of(runs)}
    n = len(pipeline) or len(counted)
    beat_tax, beat_best, run, others, short = 0, 0, 0, [], []
    none = "— (none published)" if published else "—"
    measured = set()
    for log in logs_of(runs):
        folds = folds_of(runs, log)
        if not folds:
            continue
        measured.add(log.lower())
        rows = defaultdict(list)
        above = equal = below = 0
        for fold in folds:
            f = fold_figures(runs, fold)
            for key in ("prefix-table", "lstm", "transformer", "best", "knowledge_rules"):
                rows[key].append(f[key])
            if f["leakage"] is not None:
                rows["leakage"].append(f["leakage"])
            above += f["knowledge_rules"] > f["best"]
            equal += f["knowledge_rules"] == f["best"]
            below += f["knowledge_rules"] < f["best"]
        theirs = peers.get(log.lower(), {})
        tax = theirs.get("Tax")
        top = max(theirs.items(), key=lambda kv: kv[1]) if theirs else None
        ours = 100 * statistics.mean(rows["best"])
        if log.lower() in counted:
            run += 1
            beat_tax += tax is not None and ours >= tax
            beat_best += top is not None and ours >= top[1]
            if len(folds) < 5 and pipeline:
                short.append(f"{log} ({len(folds)} folds)")
        else:
            others.append(log)
        lines.append(
            f"| {log} | {len(folds)} | {mean_sd(rows['prefix-table'])} | "
            f"{percent(rows['leakage'])} | {mean_sd(rows['lstm'])} | "
            f"{mean_sd(rows['transformer'])} | **{mean_sd(rows['best'])}** | "
            f"{mean_sd(rows['knowledge_rules'])} | {above} / {equal} / {below} | "
            f"{none if tax is None else f'{tax:.2f}'} | "
            f"{none if top is None else f'{top[1]:.2f} ({top[0]})'} |"
        )
    for log in (log for log in pipeline if log.lower() not in measured):
        theirs = peers.get(log.lower(), {})
        top = max(theirs.items(), key=lambda kv: kv[1]) if theirs else None
        tax = f"{theirs['Tax']:.2f}" if "Tax" in theirs else "—"
        lines.append(
            f"| {log} | 0 (not in the record: `LOGS={log}`) | — | — | — | — | — | — | — | "
            f"{tax} | {'—' if top is None else f'{top[1]:.2f} ({top[0]})'} |"
        )
    of = f" of the pipeline's {n}" if pipeline else ""
    tallies = [
        f"- the best model (chosen on val) at or above the best published approach: "
        f"{beat_best} of {run} log{'s' * (run != 1)} run{of};",
        f"- the best model at or above Tax et al.: {beat_tax} of {run} log{'s' * (run != 1)} "
        f"run{of}.",
    ]
    if short:
        tallies.append(f"- with fewer than 5 folds: {', '.join(short)}.")
    if others:
        tallies.append(f"- not counted above (not among the pipeline's logs): {', '.join(others)}.")
    if not published:
        tallies.append("- published figures: none given (`--published`; make: `PUBLISHED=`).")
    return lines, tallies


def lambda_text(choice: dict | None) -> str:
    """The λ chosen and each candidate's val accuracy."""
    if not choice or not choice.get("candidates"):
        return "—"
    cells = ", ".join(
        f"{c['lambda']:g}: {100 * c['val_accuracy']:.2f}" for c in choice["candidates"]
    )
    return f"{choice['value']:g} ({cells})"


def choice_table(runs: Runs) -> tuple[list[str], list[str]]:
    """Per log and fold: each grid's choice with its val accuracy, the best model, its val and
    test accuracy, the λ chosen with its candidates' val accuracies; and a count per log."""
    lines = [
        "| log | fold | LSTM chosen (val %) | Transformer chosen (val %) | best | best: val / "
        "test % | λ chosen (val % per λ) | knowledge under the rules: test % |",
        "|---|---|---|---|---|---|---|---|",
    ]
    counts = []
    for log in logs_of(runs):
        chosen: Counter = Counter()
        for fold in folds_of(runs, log):
            grid = {m: runs[f"{fold}/{m}/metrics.json"] for m in MODELS}
            best = runs[f"{fold}/best.txt"]["model"]
            knowledge = runs[f"{fold}/knowledge/metrics.json"]
            f = fold_figures(runs, fold)
            chosen[f"{best} {chosen_settings(grid[best]['settings'])}"] += 1
            cells = [
                f"{chosen_settings(grid[m]['settings'])} ({100 * grid[m]['val_accuracy']:.2f})"
                for m in MODELS
            ]
            lines.append(
                f"| {log} | {fold.split('/fold')[1]} | {cells[0]} | {cells[1]} | {best} | "
                f"{100 * grid[best]['val_accuracy']:.2f} / {100 * f['best']:.2f} | "
                f"{lambda_text(knowledge['lambda'])} | {100 * f['knowledge_rules']:.2f} |"
            )
        if chosen:
            each = [f"{k} in {v} fold{'s' * (v > 1)}" for k, v in chosen.most_common()]
            counts.append(f"- {log}: {'; '.join(each)}")
    return lines, counts


def is_training(key: str) -> bool:
    """Whether a timed command (its .times.tsv's path) is a training."""
    return Path(key).name.removesuffix(".times.tsv") in TRAININGS


def cost_table(runs: Runs, commands: dict, settings: dict) -> tuple[list[str], str]:
    """Per log: its wall minutes (the union of its timed commands' spans), its trainings' wall
    and CPU minutes (summed over the commands), the command that measured it; and the whole in
    words."""
    lines = [
        "| log | folds | wall (min) | trainings: wall, summed (min) | trainings: CPU (min) | "
        "command: `make -f pipelines/next_activity_models.mk DATA=PATH ...` |",
        "|---|---|---|---|---|---|",
    ]
    for log in logs_of(runs):
        mine = {k: c for k, c in commands.items() if k.startswith(f"{log}/")}
        trained = [c for k, c in mine.items() if is_training(k)]
        how = settings.get(log)
        command = f"`LOGS={log} {how}`" if how is not None else f"`LOGS={log}` (not recorded)"
        wall = union_seconds([(c["start"], c["end"]) for c in mine.values()])
        lines.append(
            f"| {log} | {len(folds_of(runs, log))} | {wall / 60:.0f} | "
            f"{sum(c['wall'] for c in trained) / 60:.1f} | "
            f"{sum(c['cpu'] for c in trained) / 60:.1f} | {command} |"
        )
    trained = [c for k, c in commands.items() if is_training(k)]
    wall = union_seconds([(c["start"], c["end"]) for c in commands.values()])
    text = (
        f"{wall / 60:.0f} minutes of wall time (the time some timed command of the pipeline was "
        f"running, over {len(logs_of(runs))} log{'s' * (len(logs_of(runs)) != 1)}), the "
        f"trainings {sum(c['cpu'] for c in trained) / 60:.0f} CPU minutes"
    )
    return lines, text


NOTES = """
## How to read it

- **Protocol** (Rama-Maneiro et al., IEEE TSC 2021): 5-fold cross-validation over case ids
  (`split-cases --folds 5`; each fold's validation cases are the last fifth of its training
  cases by id), accuracy pooled over every prefix of the test cases, the end of the case a
  target. Means ± standard deviation over the folds, in %.
- **Prefix table**: the next activity most often seen after the same prefix in the training
  cases (nothing learned). **Leakage**: the share of test prefixes whose exact prefix, with its
  next activity, occurs in the training cases (docs/event_logs.md, "The trivial baseline").
- **LSTM, Transformer**: each trained once per combination of its grid (`--grid`, the same
  seed), the run with the best validation accuracy kept. **Best**: per fold, whichever of the
  two grid-chosen runs has the higher validation accuracy (ties: the LSTM) — one model chosen
  across both grids on validation; test figures never choose anything.
- **Best + exact loss**: the best run's model and settings trained with the exact logic loss
  under the Declare rules mined from the fold's training cases (`mine-declare`), λ chosen on
  validation among the candidates and 0 — the λ-0 candidate is the best run itself
  (`--reference`), so where λ 0 wins the model is the best model's — then predicting under the
  mined rules (the most probable next activity, or end, that keeps them satisfiable). "Folds
  above / equal / below": its test accuracy against the best model's alone, fold by fold.
- **Published**: Rama-Maneiro et al.'s per-fold accuracies averaged over their 5 folds: Tax et
  al.'s LSTM as they re-ran it, and the best of their 12 approaches (the log's lower-cased name
  in their results). `split-cases --folds 5` on their CSVs gives their folds, case for case
  (docs/event_logs.md, "Protocols"); their models' own validation choices are theirs.
"""


def hand_written(page: Path) -> str:
    """The page's hand-written section (its heading to the next), or its placeholder."""
    text = page.read_text() if page.is_file() else ""
    if HAND not in text:
        return f"{HAND}\n\n(written by hand)\n"
    after = text.split(HAND, 1)[1]
    body = after.split("\n## ", 1)[0]
    return f"{HAND}{body.rstrip()}\n"


def page_text(kept: dict, page: Path, record: Path | None, peers: dict, published: bool) -> str:
    runs, commands, settings = kept["runs"], kept["commands"], kept["settings"]
    table, tallies = main_table(runs, peers, kept.get("pipeline", []), published)
    choices, counts = choice_table(runs)
    costs, cost = cost_table(runs, commands, settings)
    name = page.as_posix()
    rec = "" if record is None else f" --runs {record.as_posix()}"
    small = bool(settings) and all(v.startswith("SMALL=1") for v in settings.values())
    data = "SMALL=1" if small else "DATA=PATH"
    logs = ", ".join(logs_of(runs)) or "none yet"
    where = (
        "the shipped sample of the Helpdesk log (examples/event_logs/)"
        if small
        else "public event logs in Rama-Maneiro et al.'s preprocessing"
    )
    return "\n".join(
        [
            "# Results: next-activity prediction with every tleaf model, on real event logs",
            "",
            f"Measured by `make -f pipelines/next_activity_models.mk {data} PAGE={name} -j2` "
            '(the data: docs/event_logs.md, "Data for the published comparisons") on 2 CPU '
            f"cores, one thread per run: {cost}. REAL data, no synthetic data: {where} ({logs}).",
            "",
            f"This page{'' if record is None else f' and its record of runs, `{record}`,'} "
            f"{'are' if record else 'is'} rewritten only by a run given `PAGE={name}`, which "
            "adds its runs to the record; "
            f"`python pipelines/next_activity_models_report.py -o {name}{rec} --published "
            "DATA/published` rewrites the page from the record alone, keeping the hand-written "
            "section.",
            "",
            "## Next-activity accuracy, 5-fold means ± sd (%)",
            "",
            *table,
            "",
            *tallies,
            "",
            hand_written(page),
            "## The configuration chosen on validation, per fold",
            "",
            "Each grid's chosen run (hidden size × layers, learning rate; its val accuracy), the "
            "model chosen between them, and the λ chosen for the knowledge run (val accuracy per "
            "λ; λ 0 is the best run itself).",
            "",
            *choices,
            "",
            "How often each configuration was the best:",
            "",
            *counts,
            NOTES,
            "## Cost and commands",
            "",
            "Per log as its invocation ran it (`-j2`, one thread per command). Wall: the time "
            "some of the log's commands (trainings, mining, evaluations) was running, as "
            "pipelines/timed-tleaf measured them; trainings: their commands' wall seconds summed "
            "(two run at once) and their CPU seconds, every grid candidate and λ included. On "
            "cores shared with other work the wall time grows; the CPU time hardly does.",
            "",
            *costs,
            "",
            "Each fold's commands, as the pipeline runs them (`FOLD`: `OUT/<log>/fold<k>`):",
            "",
            "```bash",
            "tleaf read-log DATA/preprocessed/<log>.csv -o OUT/<log>/cases.parquet",
            "tleaf split-cases OUT/<log>/cases.parquet --folds 5 --fold <k> -o FOLD/cases.parquet",
            "tleaf train-task next-activity FOLD/cases.parquet --model prefix-table "
            "-o FOLD/prefix-table",
            "tleaf train-task next-activity FOLD/cases.parquet --model lstm "
            '--grid "hidden=64,100 layers=1,2 lr=0.001,0.002" -o FOLD/lstm',
            "tleaf train-task next-activity FOLD/cases.parquet --model transformer "
            '--grid "hidden=36,64 layers=1,2 lr=0.001,0.002" -o FOLD/transformer',
            "python pipelines/next_activity_models_report.py --choose FOLD > FOLD/best.txt",
            "tleaf mine-declare FOLD/cases.parquet -o FOLD/mined.ltl",
            "best=FOLD/$(cat FOLD/best.txt)",
            "flags=$(python pipelines/next_activity_models_report.py --flags $best)",
            "tleaf train-task next-activity FOLD/cases.parquet $flags --kb FOLD/mined.ltl \\",
            "    --logic-loss exact --lambdas 0.1,1 --reference $best -o FOLD/knowledge",
            "for m in prefix-table lstm transformer; do "
            "tleaf eval next-activity FOLD/$m FOLD/cases.parquet -o FOLD/eval-$m; done",
            "tleaf eval next-activity FOLD/knowledge FOLD/cases.parquet --rules FOLD/mined.ltl "
            "-o FOLD/eval-knowledge",
            "```",
            "",
        ]
    )


def say(step: Path, out: Path) -> str:
    """One line on a finished training (its grid's or λ's choice on val, test accuracy, CPU
    minutes) or evaluation (accuracy, under the rules, leakage)."""
    metrics = json.loads((step / "metrics.json").read_text())
    name = step.relative_to(out).as_posix() if step.is_relative_to(out) else str(step)
    if "scored_cases" in metrics:
        acc = metrics["accuracy"]
        text = f"{name}: test accuracy {100 * acc['accuracy']:.2f} %"
        if "accuracy_rules" in acc:
            text += f", under the rules {100 * acc['accuracy_rules']:.2f} %"
        if "leakage" in acc:
            text += f"; leakage {100 * acc['leakage']:.1f} %"
        return text
    text = f"{name}: val {100 * metrics['best']['val_accuracy']:.2f} %"
    grid = metrics.get("grid")
    if grid:
        text += f", {', '.join(f'{k} {v}' for k, v in grid['chosen'].items())} chosen of "
        text += f"{len(grid['candidates'])}"
    choice = metrics.get("lambda") or {}
    if choice.get("candidates"):
        text += f", λ {lambda_text(choice)}"
    text += f"; test {100 * metrics['test']['accuracy']:.2f} %"
    timed = times_of(step)
    return text + (f"; {timed['cpu_seconds'] / 60:.1f} CPU min" if timed else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?", default=None)
    parser.add_argument("-o", "--page", type=Path, default=None)
    parser.add_argument("--runs", type=Path, default=None, help="the record of runs to add to")
    parser.add_argument("--published", type=Path, default=None)
    parser.add_argument("--logs", default="", help="the logs this invocation ran")
    parser.add_argument("--all", default="", help="the pipeline's logs, named by the tally lines")
    parser.add_argument("--settings", default="", help="the settings it ran them with")
    parser.add_argument("--small", default="0", help="1: the SMALL run (its command says so)")
    parser.add_argument("--choose", type=Path, default=None, help="a fold's folder")
    parser.add_argument("--flags", type=Path, default=None, help="a grid-chosen run's folder")
    parser.add_argument("--say", type=Path, default=None, help="a finished step's folder")
    args = parser.parse_args()
    if args.choose is not None:
        print(choose(args.choose))
        return
    if args.flags is not None:
        print(flags(args.flags))
        return
    if args.say is not None:
        print(say(args.say, args.out or args.say.parent), flush=True)
        return
    if args.page is None:
        parser.error("-o PAGE.md is required")
    settings = ("SMALL=1 " if args.small == "1" else "") + args.settings
    kept = kept_runs(args.out, args.runs, args.logs.split(), settings, args.all.split())
    peers = published_accuracy(args.published)
    text = page_text(kept, args.page, args.runs, peers, args.published is not None)
    args.page.parent.mkdir(parents=True, exist_ok=True)
    args.page.write_text(text)


if __name__ == "__main__":
    main()
