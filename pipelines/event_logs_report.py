"""A results page (docs/results/event_logs.md's form) from pipelines/event_logs.mk's runs and the
peers' published figures; and the one-line summary of a finished step.

    python pipelines/event_logs_report.py [OUT] -o PAGE.md --runs RECORD.json [--published DIR]
        [--logs "rm/<log> df/<log> ..." --settings "LAMBDAS=... LOSSES=..."]
        [--rm-all "<log> ..." --df-all "<log> ..."]
    python pipelines/event_logs_report.py --say OUT/rm/<log>/fold<k>/eval-exact --out OUT

OUT: the pipeline's folder (rm/<log>/fold<k>/..., df/<log>/...); without it the page is written
from the record alone. DIR: the peers' published figures (accuracy_raw_results.csv: Rama-Maneiro
et al.'s per-fold accuracies, looked up by the log's lower-cased name; apriori_suffix_dl.csv:
Di Francescomarino et al.'s suffix similarities); a log they do not cover says so on the page.
Only what was run is reported: a log or fold without its metrics is left out, and the page says
how many folds each row has.

RECORD: the record of runs kept beside the page (JSON: each metrics.json of OUT by its path in
OUT, the fields the report reads, each log folder's wall time). The runs of OUT are added to it
(replacing the same paths), and the page is written from all of it: the whole pipeline takes
hours, and runs measured by separate invocations (some logs now, others later, each `make ...
RM_LOGS=... DF_LOGS=...` on the same code) add up to one page. `--logs` names the log folders
this invocation ran and `--settings` the pipeline settings it ran them with: the record keeps
them per log, and the page's last table gives each log the command that measured it.
`--rm-all`/`--df-all`: the pipeline's own logs, those the goal lines count (kept in the record).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import statistics
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

Runs = dict[str, dict]  # a metrics.json's path in OUT ("rm/Helpdesk/fold0/eval-none/...") -> it


def times_of(run: Path) -> dict:
    """A training's wall and CPU seconds as pipelines/timed-tleaf wrote them beside its folder
    (<run>.times.tsv: wall, user, system, command; the last complete line), or {}."""
    path = run.parent / f"{run.name}.times.tsv"
    fields = None
    for line in path.read_text().splitlines() if path.is_file() else []:
        parts = line.split("\t")
        try:
            fields = [float(x) for x in parts[:3]] if len(parts) >= 4 else fields
        except ValueError:  # GNU time's "Command exited with non-zero status" line
            continue
    if fields is None:
        return {}
    return {"wall_seconds": fields[0], "cpu_seconds": round(fields[1] + fields[2], 2)}


def runs_of(out: Path | None) -> Runs:
    """Every metrics.json under `out`, by its path there, reduced to what the report reads: an
    evaluation's accuracy and suffix scores; a training run's epoch seconds (wall clock), its λ
    and candidates, and, for a run the pipeline timed, its CPU seconds."""
    runs: Runs = {}
    if out is None or not out.is_dir():
        return runs
    for path in sorted(out.rglob("metrics.json")):
        metrics = json.loads(path.read_text())
        key = path.relative_to(out).as_posix()
        if "suffix" in metrics:  # eval next-activity
            runs[key] = {k: metrics[k] for k in ("accuracy", "suffix", "scored_cases")}
        elif metrics.get("task") == "next-activity":  # train-task next-activity
            seconds = sum(h["seconds"] for h in metrics["history"])
            runs[key] = {"train_seconds": seconds, "lambda": metrics.get("lambda")}
            runs[key].update(times_of(path.parent))
    return runs


def wall_minutes(folder: Path) -> float | None:
    """A log's wall time: its folder's first artifact written to its last (the files' times)."""
    stamps = [p.stat().st_mtime for p in folder.rglob("*") if p.is_file()]
    return (max(stamps) - min(stamps)) / 60 if stamps else None


def kept_runs(
    out: Path | None, record: Path | None, logs: list[str] = (), settings: str = "",
    pipeline: dict[str, list[str]] | None = None,
) -> dict:  # fmt: skip
    """The runs of `out` added to the `record` file (rewritten, atomically; without `out`, read
    only): {"runs", "walls":
    the wall minutes of every log folder (`rm/<log>`, `df/<log>`) that measured some, per log,
    not per OUT, so that invocations into one OUT hours apart do not count the hours between
    them; "settings": each log's (`settings` for the folders in `logs`); "pipeline": the
    pipeline's own logs per protocol, as last given}."""
    kept = {"runs": {}, "walls": {}}
    if record is not None and record.is_file():
        kept = json.loads(record.read_text())
    kept.setdefault("settings", {})
    kept.setdefault("pipeline", {})
    for log in logs:
        kept["settings"][log] = settings
    for part, names in (pipeline or {}).items():
        if names:
            kept["pipeline"][part] = names
    fresh = runs_of(out)
    kept["runs"].update(fresh)
    for log in sorted({"/".join(Path(name).parts[:2]) for name in fresh}):
        minutes = wall_minutes(out / log)
        if minutes is not None:  # a log's wall time grows with each invocation into it
            kept["walls"][log] = round(minutes, 1)
    if record is not None and out is not None:  # the page from the record alone leaves it
        record.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=record.parent, delete=False) as f:
            json.dump(kept, f, indent=1, sort_keys=True)
        os.chmod(f.name, 0o644)
        os.replace(f.name, record)
    return kept


def folders(runs: Runs, part: str) -> list[str]:
    """The logs `runs` holds in `part` (rm or df)."""
    return sorted({k.split("/")[1] for k in runs if k.startswith(part + "/")}, key=str.lower)


def similarity(row: dict | None, way: str) -> str:
    """A suffix row's DL similarity for `way`, or — where the row was not measured."""
    return "—" if row is None else f"{row[way]['dl_similarity']:.3f}"


def folds_of(values: list[float], done: int) -> str:
    """' (n folds)' where a column has fewer folds than its row."""
    return "" if not values or len(values) == done else f" ({len(values)} folds)"


def mean_sd(values: list[float]) -> str:
    if not values:
        return "—"
    if len(values) == 1:
        return f"{100 * values[0]:.2f}"
    return f"{100 * statistics.mean(values):.2f} ± {100 * statistics.stdev(values):.2f}"


def lam(value: float) -> str:
    return f"{value:g}"


def peers_file(folder: Path, name: str) -> Path:
    path = folder / name
    if not path.is_file():
        sys.exit(f"error: {path}: no such file (the peers' published figures; --published DIR)")
    return path


def published_accuracy(folder: Path | None) -> dict[str, dict[str, float]]:
    """log (lower case) -> approach -> mean accuracy over folds (%)."""
    if folder is None:
        return {}
    runs: dict[tuple[str, str], list[float]] = defaultdict(list)
    with open(peers_file(folder, "accuracy_raw_results.csv"), newline="") as f:
        for row in csv.DictReader(f):
            runs[(row["log"], row["approach"])].append(float(row["accuracy"]))
    out: dict[str, dict[str, float]] = defaultdict(dict)
    for (log, approach), values in runs.items():
        out[log][approach] = 100 * statistics.mean(values)
    return out


def published_suffix(folder: Path | None) -> dict[tuple[str, str, str, int], float]:
    """(log, formula, method, prefix length) -> DL similarity."""
    if folder is None:
        return {}
    with open(peers_file(folder, "apriori_suffix_dl.csv"), newline="") as f:
        return {
            (r["log"], r["formula"], r["method"], int(r["prefix_length"])): float(
                r["dl_similarity"]
            )
            for r in csv.DictReader(f)
        }


def rules_moved(evals: list[dict]) -> str:
    """What prediction under the mined rules did to `evals` (one per fold): the predictions it
    changed where the evaluation counts them, else the folds whose accuracy it moved."""
    if not evals:
        return "—"
    counts = [e["accuracy"].get("changed_by_rules") for e in evals]
    if all(c is not None for c in counts):
        total = sum(e["accuracy"]["prefixes"] for e in evals)
        return f"{sum(counts)} of {total} predictions changed"
    moved = sum(e["accuracy"].get("accuracy_rules", e["accuracy"]["accuracy"])
                != e["accuracy"]["accuracy"] for e in evals)  # fmt: skip
    return f"accuracy moved in {moved} of {len(evals)} folds"


def rm_table(
    runs: Runs, peers: dict[str, dict[str, float]], pipeline: list[str] = (),
    published: bool = True,
) -> tuple[list[str], list[str]]:  # fmt: skip
    """Rama-Maneiro et al.'s protocol: the table's lines and the goals' lines; a log of
    `pipeline` (the pipeline's own logs, those the goals count) with no run in the record gets a
    row that says so.

    The knowledge model is declared before the runs: the exact loss's run (λ chosen on val
    among the candidates and 0) predicting under the mined rules. The other columns are shown,
    not chosen among on test."""
    lines = [
        "| log | folds | no knowledge | exact loss (λ on val) | tleaf loss (λ on val) | no "
        "knowledge, under mined rules | **exact, under mined rules** | folds above / equal / "
        "below no knowledge | mined rules on the exact run | Tax et al. | best published |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    counted = {log.lower() for log in pipeline} or {log.lower() for log in folders(runs, "rm")}
    beat_tax, beat_best, raised, run, with_tax, unpublished, others = 0, 0, 0, 0, 0, [], []
    for log in folders(runs, "rm"):
        rows, exact_evals = defaultdict(list), []
        above, equal, below, done = 0, 0, 0, 0
        fold_names = {k.split("/")[2] for k in runs if k.startswith(f"rm/{log}/fold")}
        for fold in (f"rm/{log}/{name}" for name in sorted(fold_names)):
            none = runs.get(f"{fold}/eval-none/metrics.json")
            exact = runs.get(f"{fold}/eval-exact/metrics.json")
            if none is None or exact is None:
                continue
            done += 1
            exact_evals.append(exact)
            a_none = none["accuracy"]["accuracy"]
            rows["none"].append(a_none)
            rows["exact"].append(exact["accuracy"]["accuracy"])
            rows["none_rules"].append(none["accuracy"].get("accuracy_rules", a_none))
            rows["exact_rules"].append(exact["accuracy"].get("accuracy_rules", a_none))
            tleaf = runs.get(f"{fold}/eval-tleaf/metrics.json")
            if tleaf is not None:
                rows["tleaf"].append(tleaf["accuracy"]["accuracy"])
            ours = rows["exact_rules"][-1]
            above, equal, below = above + (ours > a_none), equal + (ours == a_none), below + (
                ours < a_none)  # fmt: skip
        if not done:
            continue
        theirs = peers.get(log.lower(), {})
        tax = theirs.get("Tax")
        best = max(theirs.items(), key=lambda kv: kv[1]) if theirs else None
        if not theirs:
            unpublished.append(log)
        if log.lower() in counted:
            run += 1
            with_tax += tax is not None
            ours = 100 * statistics.mean(rows["exact_rules"])
            beat_tax += tax is not None and ours >= tax
            beat_best += best is not None and ours >= best[1]
            raised += done >= 4 and above >= 4
        else:
            others.append(log)
        none_published = "— (none published)" if published else "—"
        lines.append(
            f"| {log} | {done} | {mean_sd(rows['none'])} | {mean_sd(rows['exact'])} | "
            f"{mean_sd(rows['tleaf'])}{folds_of(rows['tleaf'], done)} | "
            f"{mean_sd(rows['none_rules'])} | **{mean_sd(rows['exact_rules'])}** | "
            f"{above} / {equal} / {below} | {rules_moved(exact_evals)} | "
            f"{none_published if tax is None else f'{tax:.2f}'} | "
            f"{none_published if best is None else f'{best[1]:.2f} ({best[0]})'} |"
        )
    measured = {log.lower() for log in folders(runs, "rm")}
    for log in [log for log in pipeline if log.lower() not in measured]:  # say it is missing
        theirs = peers.get(log.lower(), {})
        best = max(theirs.items(), key=lambda kv: kv[1]) if theirs else None
        tax = f"{theirs['Tax']:.2f}" if "Tax" in theirs else "—"
        lines.append(
            f"| {log} | 0 (not in the record: `RM_LOGS={log}`) | — | — | — | — | — | — | — | "
            f"{tax} | {'—' if best is None else f'{best[1]:.2f} ({best[0]})'} |"
        )
    n = len(pipeline) or run  # the goals: all, half, two thirds of the pipeline's logs

    def goal(k: int) -> str:
        return (
            f"goal: {'all' if k == n else k} of {'the pipeline' if pipeline else 'those run'}'s {n}"
        )

    goals = [
        f"- exact under mined rules at or above Tax et al.: {beat_tax} of the {with_tax} logs run "
        f"that they measured ({goal(n)});",
        f"- at or above the best published approach: {beat_best} of {run} logs run "
        f"({goal(-(-n // 2))});",
        f"- above tleaf's own no-knowledge model in at least 4 of 5 folds: {raised} of {run} logs "
        f"run ({goal(-(-2 * n // 3))}).",
    ]
    if others:
        goals.append(f"- not counted above (not among the pipeline's logs): {', '.join(others)}.")
    if unpublished and published:
        goals.append(
            "- no published figures for " + ", ".join(f"{log} (looked up as `{log.lower()}`)"
            for log in unpublished) + ": the peers' `log` column names each log in lower case."
        )  # fmt: skip
    if not published:
        goals.append("- published figures: none given (`--published`; make: `PUBLISHED=`).")
    return lines, goals


def df_table(runs: Runs, peers: dict, pipeline: list[str] = ()) -> tuple[list[str], list[str]]:
    """Di Francescomarino et al.'s protocol: the table's lines and the goals' lines (the goals
    count the logs of `pipeline`, or every log where it is empty)."""
    lines = [
        "| log | formula | prefix | cases | their baseline | their a-priori | argmax | beam | "
        "under the formula (satisfying) | under mined rules | exact loss: argmax / under the "
        "formula | tleaf loss: argmax / under the formula |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    cells, met, mined_logs, logs_run = 0, 0, set(), set()
    mined_cells: dict[str, list[bool]] = defaultdict(list)
    counted = set(pipeline) or set(folders(runs, "df"))  # the logs the goals count
    for log in folders(runs, "df"):
        for formula in ("strong", "weak"):
            none = runs.get(f"df/{log}/eval-none-{formula}/metrics.json")
            mined = runs.get(f"df/{log}/eval-none-{formula}-mined/metrics.json")
            exact = runs.get(f"df/{log}/eval-exact-{formula}/metrics.json")
            tleaf = runs.get(f"df/{log}/eval-tleaf-{formula}/metrics.json")
            if none is None:
                continue
            if log in counted:
                logs_run.add(log)
            for k, row in none["suffix"].items():
                if not row.get("cases"):
                    continue
                base = peers.get((log, formula, "baseline", int(k)))
                apriori = peers.get((log, formula, "apriori", int(k)))
                under = row["rules"]
                m = None if mined is None else mined["suffix"][k]["rules"]["dl_similarity"]
                # prefixes that already broke the mined rules: searched without them
                lost = 0 if mined is None else mined["suffix"][k]["rules"].get("not_found", 0)
                e = None if exact is None else exact["suffix"][k]
                t = None if tleaf is None else tleaf["suffix"][k]
                cells += log in counted
                ok = apriori is None or (
                    under["dl_similarity"] >= apriori and under["satisfying"] == 1.0
                )
                met += ok and log in counted
                if m is not None:
                    kept = lost <= row["cases"] / 2  # the rules steered most of the cell
                    mined_cells[log].append(kept and m > row["argmax"]["dl_similarity"])
                lines.append(
                    f"| {log} | {formula} | {k} | {row['cases']} | "
                    f"{'—' if base is None else f'{base:.2f}'} | "
                    f"{'—' if apriori is None else f'{apriori:.2f}'} | "
                    f"{row['argmax']['dl_similarity']:.3f} | {row['beam']['dl_similarity']:.3f} | "
                    f"{under['dl_similarity']:.3f} ({100 * under['satisfying']:.0f} %) | "
                    f"{'—' if m is None else f'{m:.3f}'}"
                    f"{f' ({lost} broken)' if lost else ''} | "
                    f"{similarity(e, 'argmax')} / {similarity(e, 'rules')} | "
                    f"{similarity(t, 'argmax')} / {similarity(t, 'rules')} |"
                )
    for log, wins in ((log, w) for log, w in mined_cells.items() if log in counted):
        if wins and sum(wins) > len(wins) / 2:
            mined_logs.add(log)
    n, k = len(pipeline), -(-4 * len(pipeline) // 5)  # four of the five
    aim = f"{'all' if k == n else k} of the pipeline's {n}" if pipeline else "four of five"
    goals = [
        f"- under the formula at or above their a-priori figure with 100 % satisfying: {met} of "
        f"{cells} cells (goal: every cell);",
        f"- under the mined rules above argmax in most of a log's cells: {len(mined_logs)} of "
        f"{len(logs_run)} logs run (goal: {aim}); a cell whose prefixes mostly broke the mined "
        'rules already ("n broken": searched without them) does not count.',
    ]
    others = [log for log in folders(runs, "df") if log not in counted]
    if others:
        goals.append(f"- not counted above (not among the pipeline's logs): {', '.join(others)}.")
    return lines, goals


def lambda_table(runs: Runs) -> list[str]:
    """Per log and loss: the λ each fold chose on validation and every candidate's validation
    accuracy (mean over the folds, and the lowest), so that a λ that collapsed is seen."""
    lines = [
        "| log | protocol | loss | λ chosen (per fold) | validation accuracy per candidate "
        "(mean %, lowest fold) |",
        "|---|---|---|---|---|",
    ]
    for part, protocol in (("rm", "Rama-Maneiro"), ("df", "Di Francescomarino")):
        for log in folders(runs, part):
            for loss in ("exact", "tleaf"):
                keys = sorted(k for k in runs if k.startswith(f"{part}/{log}/")
                              and k.endswith(f"/{loss}/metrics.json"))  # fmt: skip
                choices = [runs[k]["lambda"] for k in keys if (runs[k].get("lambda") or {})
                           .get("candidates")]  # fmt: skip
                if not choices:
                    continue
                val: dict[float, list[float]] = defaultdict(list)
                for choice in choices:
                    for c in choice["candidates"]:
                        val[c["lambda"]].append(c["val_accuracy"])
                cells = [
                    f"λ {lam(x)}: {100 * statistics.mean(v):.2f}"
                    + (f" ({100 * min(v):.2f})" if len(v) > 1 else "")
                    for x, v in sorted(val.items())
                ]
                chosen = ", ".join(lam(c["value"]) for c in choices)
                lines.append(f"| {log} | {protocol} | {loss} | {chosen} | {' · '.join(cells)} |")
    return lines


def training(runs: Runs, prefix: str = "") -> tuple[float, float | None, int, int]:
    """The training runs under `prefix`: their epochs' wall seconds (each λ candidate once: the
    tleaf run's λ-0 candidate is the exact run's reference), the CPU seconds of the runs the
    pipeline timed (None if none), and how many of the trainings were timed, of how many."""
    epochs = sum(
        m["train_seconds"] for k, m in runs.items() if k.startswith(prefix)
        and "/lambda-choice/" in k and not k.endswith("/tleaf/lambda-choice/lambda-0/metrics.json")
    )  # fmt: skip
    tops = [m for k, m in runs.items() if k.startswith(prefix) and "train_seconds" in m
            and "/lambda-choice/" not in k]  # fmt: skip
    timed = [m["cpu_seconds"] for m in tops if "cpu_seconds" in m]
    return epochs, (sum(timed) if timed else None), len(timed), len(tops)


def cost(runs: Runs, walls: dict[str, float]) -> str:
    """The page's cost: wall time, CPU time of training where measured, the epochs' wall time."""
    epochs, cpu, timed, trainings = training(runs)
    text = (f"{sum(walls.values()):.0f} minutes of wall time (summed over {len(walls)} log runs)"
            if walls else "no runs")  # fmt: skip
    if cpu is None:
        text += ", training CPU time not measured"
    else:
        text += f", {cpu / 60:.1f} CPU minutes of training"
        text += "" if timed == trainings else f" ({timed} of {trainings} trainings measured)"
    return text + (f"; the training epochs took {epochs / 60:.1f} minutes by the wall clock "
                   "(every λ candidate's run, one thread each)")  # fmt: skip


def runs_table(runs: Runs, walls: dict[str, float], settings: dict[str, str]) -> list[str]:
    """Per log folder: the command that measured it (settings the record does not hold: '?'),
    its wall time, its training epochs' wall time and its training's CPU time."""
    lines = [
        "| log | protocol | command: `make -f pipelines/event_logs.mk DATA=PATH ...` | wall "
        "(min) | training epochs, wall (min) | training CPU (min) |",
        "|---|---|---|---|---|---|",
    ]
    for log in sorted(walls, key=str.lower):
        part, name = log.split("/", 1)
        logs = f"RM_LOGS={name} DF_LOGS=" if part == "rm" else f"RM_LOGS= DF_LOGS={name}"
        how = settings.get(log)
        command = f"`{logs} {how}`" if how is not None else f"`{logs}` (settings not recorded)"
        epochs, cpu, timed, trainings = training(runs, log + "/")
        cpu_text = "not measured" if cpu is None else f"{cpu / 60:.1f}"
        cpu_text += "" if cpu is None or timed == trainings else f" ({timed} of {trainings} runs)"
        protocol = "Rama-Maneiro (5 folds)" if part == "rm" else "Di Francescomarino"
        lines.append(
            f"| {name} | {protocol} | {command} | {walls[log]:.0f} | {epochs / 60:.1f} | "
            f"{cpu_text} |"
        )
    return lines


NOTES = """
## How to read it

- Every model is the same LSTM (docs/event_logs.md), trained once per log and fold with the exact
  logic loss under the Declare rules mined from that fold's training split; λ is chosen on the
  fold's validation cases among the candidates and **0**, and the λ-0 run is the no-knowledge
  reference (same seed). The tleaf loss's runs read a q trained on those mined rules alone
  (40 synthetic traces per rule, 10 for env_permit's df rows; a minute per log or fold),
  λ chosen the same way.
- "Folds above / equal / below": the knowledge model's test accuracy against the no-knowledge
  model's, fold by fold; "equal" is the same accuracy, as where λ 0 was chosen and the mined
  rules moved no accuracy. "Mined rules on the exact run": whether predicting under them moved
  the chosen run's accuracy.
- "Under mined rules": each prediction is the most probable next activity
  (or end) that keeps the mined rules satisfiable. The knowledge model (bold) was declared before
  the runs; the other columns are shown, not chosen among on test.
- Published figures: Rama-Maneiro et al.'s per-fold accuracies averaged over their 5 folds (Tax et
  al.'s LSTM as they re-ran it, and the best of their 12 approaches), looked up by the log's name
  in lower case; Di Francescomarino et al.'s suffix similarities as printed (their LSTM alone,
  and with their a-priori beam search).
- Suffixes: from each test case with at least k activities that satisfies the formula, by argmax,
  by beam search (width 5), and by the same search in the product of the model and the formula's
  (or the mined rules') DFA. "exact loss" columns: the λ-chosen run instead of the reference.
"""


def say(step: Path, out: Path) -> str:
    """One line on a finished step of the pipeline: a training (the λ chosen among the
    candidates' validation accuracies, test accuracy, CPU minutes) or an evaluation (accuracy,
    under the rules; suffix similarities)."""
    metrics = json.loads((step / "metrics.json").read_text())
    name = step.relative_to(out).as_posix() if step.is_relative_to(out) else str(step)
    if "suffix" in metrics:
        acc = metrics["accuracy"]
        text = f"{name}: test accuracy {100 * acc['accuracy']:.2f} %"
        if "accuracy_rules" in acc:
            text += f", under the rules {100 * acc['accuracy_rules']:.2f} %"
        if metrics["suffix"]:
            rows = [r for r in metrics["suffix"].values() if r.get("cases")]
            way = {w: [r[w]["dl_similarity"] for r in rows] for w in ("argmax", "rules")}
            text += (
                "; suffix similarity, "
                + ", ".join(f"{w} {min(v):.3f}–{max(v):.3f}" for w, v in way.items() if v)
                + f" over prefix lengths {', '.join(metrics['suffix'])}"
            )
        return text
    choice = metrics.get("lambda") or {}
    text = f"{name}: λ {lam(choice.get('value', 0))}"
    if choice.get("candidates"):
        text += " chosen on validation among " + ", ".join(
            f"{lam(c['lambda'])} ({100 * c['val_accuracy']:.2f} %)" for c in choice["candidates"]
        )
    text += f"; test accuracy {100 * metrics['test']['accuracy']:.2f} %"
    timed = times_of(step)
    return text + (f"; {timed['cpu_seconds'] / 60:.1f} CPU min" if timed else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?", default=None)
    parser.add_argument("-o", "--report", type=Path, default=None)
    parser.add_argument("--published", type=Path, default=None)
    parser.add_argument("--runs", type=Path, default=None, help="the record of runs to add to")
    parser.add_argument("--logs", default="", help="the log folders this invocation ran")
    parser.add_argument("--settings", default="", help="the settings it ran them with")
    parser.add_argument("--rm-all", default="", help="the pipeline's logs of the 5-fold table")
    parser.add_argument("--df-all", default="", help="the pipeline's logs of the suffix table")
    parser.add_argument("--say", type=Path, default=None, help="a finished step's folder")
    args = parser.parse_args()
    if args.say is not None:
        print(say(args.say, args.out or args.say.parent), flush=True)
        return
    if args.report is None:
        parser.error("-o PAGE.md is required")
    pipeline = {"rm": args.rm_all.split(), "df": args.df_all.split()}
    kept = kept_runs(args.out, args.runs, args.logs.split(), args.settings, pipeline)
    runs, walls, settings, pipeline = (
        kept["runs"],
        kept["walls"],
        kept["settings"],
        kept["pipeline"],
    )
    published = args.published is not None
    rm, rm_goals = rm_table(runs, published_accuracy(args.published), pipeline.get("rm", []),
                            published)  # fmt: skip
    df, df_goals = df_table(runs, published_suffix(args.published), pipeline.get("df", []))
    page = args.report.as_posix()
    record = "" if args.runs is None else f" and its record of runs, `{args.runs.as_posix()}`"
    text = "\n".join(
        [
            "# Results: next-activity and suffix prediction on real event logs",
            "",
            f"Measured by `make -f pipelines/event_logs.mk DATA=PATH PAGE={page} -j2` "
            "(docs/event_logs.md: the data, the protocols) on 2 CPU cores, one log at a time "
            f"(each log's command: the last table): {cost(runs, walls)}.",
            "",
            f"This page{record}, are rewritten only by a run given `PAGE={page}`: it adds the "
            "runs of its `OUT` to the record and writes the page from the whole record (without "
            "`PAGE=`, a run writes its page and record into its `OUT`). `python "
            f"pipelines/event_logs_report.py -o {page}"
            + ("" if args.runs is None else f" --runs {args.runs.as_posix()}")
            + " --published DATA/published` rewrites the page from the record alone.",
            "",
            "## Next-activity accuracy, Rama-Maneiro et al.'s protocol (5-fold means ± sd, %)",
            "",
            *rm,
            "",
            *rm_goals,
            "",
            "## λ chosen on validation",
            "",
            "Each run trains one model per λ candidate and keeps the best on its validation "
            "cases; a candidate that collapsed shows here (lowest fold), not in the tables.",
            "",
            *lambda_table(runs),
            "",
            "## Suffix similarity, Di Francescomarino et al.'s protocol (Damerau-Levenshtein)",
            "",
            *df,
            "",
            *df_goals,
            NOTES,
            "## Runs behind the rows",
            "",
            "Each log as its invocation ran it (one log at a time, `-j2` on 2 cores unless the "
            "cores were shared; wall: the log folder's first artifact to its last; training "
            "CPU: user and system seconds of the training commands, as pipelines/timed-tleaf "
            "measured them):",
            "",
            *runs_table(runs, walls, settings),
            "",
        ]
    )
    args.report.parent.mkdir(parents=True, exist_ok=True)
    args.report.write_text(text)


if __name__ == "__main__":
    main()
