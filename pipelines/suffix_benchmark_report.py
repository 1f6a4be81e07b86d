"""The suffix benchmark on real event logs (pipelines/suffix_benchmark.mk): its page.

Reads OUT/<log>/fold<k>/{val,test}/metrics.json (eval next-activity with every way, its
`suffix_pooled`: the DL similarity pooled over every (case, prefix) pair, as Rama-Maneiro et
al.'s "Mean DL") and OUT/<log>/fold<k>/*.times.tsv (each command's wall and CPU seconds), and
writes a page:

- per log, each way's test DL similarity (×100), mean ± sd over the folds; the way chosen per
  fold on validation (the best pooled DL there) and its test figure; the share of its predicted
  suffixes that reach the length cap beside the share of true suffixes that long; Tax et al.'s
  and the best published approach's mean over their folds (their suffix_full_results.csv);
- per fold, the way chosen and every way's validation figure;
- the cost of each log on the machine that ran it.

    python pipelines/suffix_benchmark_report.py OUT -o PAGE.md --logs "A B" [--published CSV]
        [--command "make ..."]
    python pipelines/suffix_benchmark_report.py --longest CASES   # the longest case's events
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import sys
from collections import defaultdict
from pathlib import Path

WAYS = {  # eval's way -> the page's name
    "argmax": "argmax",
    "beam": "beam",
    "mbr": "MBR",
    "argmax_rules": "argmax, rules",
    "rules": "beam, rules",
    "mbr_rules": "MBR, rules",
}


INPUTS = "inputs"  # the variant whose model reads the log's attributes (INPUTS=1)


def read_fold(units: dict[str, Path]) -> dict | None:
    """A fold's pooled figures per split ({"val": {...}, "test": {...}}) over its variants
    (label -> the fold's folder; a way of the variant "inputs" keyed "inputs:way"), None
    unless every variant has both splits."""
    out: dict = {"val": {}, "test": {}}
    for label, unit in units.items():
        for split in ("val", "test"):
            path = unit / split / "metrics.json"
            if not path.is_file():
                return None
            pooled = json.loads(path.read_text())["suffix_pooled"]
            for key, figures in pooled.items():
                if isinstance(figures, dict):
                    out[split][f"{label}:{key}" if label else key] = figures
                elif not label:
                    out[split][key] = figures
    return out


def name(key: str) -> str:
    """A way's name on the page ("inputs:mbr" -> "MBR, attributes read")."""
    label, _, way = key.rpartition(":")
    return WAYS[way] + (", attributes read" if label else "")


def keys_of(figures: dict) -> list[str]:
    """The ways of a fold's figures, in the page's order: the plain model's, then the inputs'."""
    order = [*WAYS, *(f"{INPUTS}:{w}" for w in WAYS)]
    return [k for k in order if k in figures]


def chosen_way(val: dict) -> str:
    """The way with the best pooled DL similarity on validation (ties: the first)."""
    ways = keys_of(val)
    return max(ways, key=lambda w: (val[w]["dl_similarity"], -ways.index(w)))


def spread(values: list[float]) -> str:
    if not values:
        return "–"
    mean = statistics.fmean(values)
    sd = statistics.stdev(values) if len(values) > 1 else 0.0
    return f"{100 * mean:.2f} ± {100 * sd:.2f}"


def published(path: Path | None) -> dict[str, dict[str, float]]:
    """log (lower case) -> approach -> its DL similarity, mean over the folds."""
    if path is None:
        return {}
    values: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    with path.open(newline="") as f:
        for row in csv.DictReader(f):
            values[row["log"]][row["approach"]].append(float(row["accuracy"]))
    return {
        log: {a: statistics.fmean(v) for a, v in approaches.items()}
        for log, approaches in values.items()
    }


def seconds(unit: Path) -> tuple[float, float]:
    """Wall and CPU seconds of a fold's timed commands."""
    wall = cpu = 0.0
    for times in unit.glob("*.times.tsv"):
        for line in times.read_text().splitlines():
            fields = line.split("\t")
            wall += float(fields[0])
            cpu += float(fields[1]) + float(fields[2])
    return wall, cpu


def page(out: Path, logs: list[str], peers: dict, command: str, inputs: Path | None = None) -> str:
    summary, details, costs = [], [], []
    above = 0
    columns = [*WAYS, f"{INPUTS}:mbr"] if inputs is not None else list(WAYS)
    for log in logs:
        variants = {"": out / log}
        if inputs is not None and (inputs / log).is_dir():
            variants[INPUTS] = inputs / log
        names = sorted({u.name for u in (out / log).glob("fold*")})
        read = [(k, read_fold({v: d / k for v, d in variants.items()})) for k in names]
        folds = [(k, f) for k, f in read if f is not None]
        if not folds:
            continue
        ways = keys_of(folds[0][1]["test"])
        choice = [chosen_way(f["val"]) for _, f in folds]
        chosen = [f["test"][w]["dl_similarity"] for (_, f), w in zip(folds, choice, strict=True)]
        capped = [f["test"][w]["at_cap"] for (_, f), w in zip(folds, choice, strict=True)]
        true_capped = [f["test"]["true_at_cap"] for _, f in folds]
        theirs = peers.get(log.lower(), {})
        best = max(theirs.items(), key=lambda kv: kv[1]) if theirs else None
        mine = statistics.fmean(chosen)
        if best is not None and mine >= best[1]:
            above += 1
        cells = [
            spread([f["test"][w]["dl_similarity"] for _, f in folds]) if w in ways else "–"
            for w in columns
        ]
        cap = f"{100 * statistics.fmean(capped):.1f} / {100 * statistics.fmean(true_capped):.1f}"
        summary.append(
            [
                log,
                str(len(folds)),
                str(folds[0][1]["test"]["prefixes"]),
                *cells,
                f"**{spread(chosen)}**",
                cap,
                f"{100 * theirs['Tax']:.2f}" if "Tax" in theirs else "–",
                f"{100 * best[1]:.2f} ({best[0]})" if best else "–",
            ]
        )
        for (fold, f), w in zip(folds, choice, strict=True):
            val = ", ".join(f"{name(x)} {100 * f['val'][x]['dl_similarity']:.2f}" for x in ways)
            test = f"{100 * f['test'][w]['dl_similarity']:.2f}"
            details.append([log, fold, name(w), val, test])
        units = [d / k for k, _ in folds for d in variants.values()]
        wall, cpu = map(sum, zip(*(seconds(u) for u in units), strict=True))
        costs.append([log, str(len(folds)), f"{wall / 60:.1f}", f"{cpu / 60:.1f}"])
    header = ["log", "folds", "test prefixes (fold 1)"] + [name(w) for w in columns]
    header += [
        "**chosen on val**",
        "chosen: at the cap / true suffixes that long (%)",
        "Tax et al. (published)",
        "best published",
    ]
    lines = [
        "# Results: suffix prediction on real event logs (Rama-Maneiro et al.'s benchmark)",
        "",
        f"Measured by `{command}` on 2 CPU cores. REAL data: public event logs in Rama-Maneiro "
        "et al.'s preprocessing and folds.",
        "",
        "## Suffix DL similarity, means ± sd over the folds (×100)",
        "",
        "Damerau-Levenshtein similarity of the predicted and the true rest of the case, pooled "
        "over every (case, prefix of 1 .. n−1 events) pair of a fold's test cases, as their "
        "`tax/code/train.py --test_suffix` computes it; the cap on a predicted suffix is the "
        "log's longest case.",
        "",
        _table(header, summary),
        "",
        f"- the way chosen on validation at or above the best published approach: {above} of "
        f"{len(summary)} logs.",
        "",
        "## How to read it",
        "",
        "- **Ways** (eval next-activity, docs/event_logs.md): argmax (Tax et al.'s: the most "
        "probable next activity until the end), beam (width BEAM), MBR (minimum Bayes risk: of "
        "SAMPLES draws from the model, the one with the highest mean DL similarity to the "
        'others); "rules": the same under the Declare rules mined on the fold\'s train '
        'split, a hard filter; "attributes read": the model reads the attributes the CSVs '
        "drop (INPUTS=1; pipelines/log_attributes.mk), its ways scored alike.",
        "- **Chosen on val**: per fold, the way (and model) with the best pooled DL similarity "
        "on the fold's validation cases (the last fifth of its training cases by id), its test "
        "figure reported; test figures choose nothing. Validation and test disagree on some "
        "logs (a drift over case ids): the per-fold table shows both.",
        "- **At the cap**: the share of the chosen way's predicted suffixes that run to the "
        "cap (a loop) beside the share of true suffixes that long.",
        "- **Published**: Rama-Maneiro et al.'s per-fold results (their "
        "suffix_full_results.csv), means over their five folds; their folds are these.",
        "",
        "## The way chosen on validation, per fold",
        "",
        _table(["log", "fold", "chosen", "val DL per way", "test DL"], details),
        "",
        "## Cost",
        "",
        "Every command of the log's folds (training, mining, both evaluations; both models where "
        "the attributes were read too), on 2 cores shared by the runs, as "
        "pipelines/timed-tleaf measured them.",
        "",
        _table(["log", "folds", "wall (min, summed)", "CPU (min)"], costs),
        "",
    ]
    return "\n".join(lines)


def _table(header: list[str], rows: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path)
    parser.add_argument("-o", "--page", type=Path)
    parser.add_argument("--logs", default="")
    parser.add_argument("--published", type=Path)
    parser.add_argument("--inputs", type=Path, help="the INPUTS=1 run's OUT, a variant more")
    parser.add_argument("--command", default="make -f pipelines/suffix_benchmark.mk DATA=PATH")
    parser.add_argument("--longest", type=Path, help="print the longest case's event count")
    args = parser.parse_args(argv)
    if args.longest is not None:
        from tleaf_cli.data.event_logs import read_cases

        print(max(len(c) for c in read_cases(args.longest).cases))
        return 0
    if args.out is None or args.page is None:
        parser.error("OUT and -o PAGE are needed")
    text = page(args.out, args.logs.split(), published(args.published), args.command, args.inputs)
    tmp = args.page.with_suffix(".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(args.page)
    return 0


if __name__ == "__main__":
    sys.exit(main())
