"""Mezini et al.'s protocol on any of their logs: the settings and the model a log calls for.

Two commands (pipelines/mezini.mk runs both):

    python pipelines/mezini_data.py settings TRAIN.xes.gz ... --test TEST.xes.gz
        Prints `PREFIXES MAX_SUFFIX` as their runner chooses them per log (src/runner.py and
        src/common/event_log.py of github axelmezini/nesy-suffix-prediction-dfa): the prefix
        lengths floor(m / 2), floor(m / 2) + 1, floor(m / 2) + 2, m the median length of the
        training cases (each noise level's training log: relabelling keeps every length, and
        this checks it); the longest suffix, the test log's longest case (their sampler stops
        there). Lengths are events per XES trace, as their reader (pm4py) counts them. Standard
        library only: make runs it while it reads the makefile.

    python pipelines/mezini_data.py kb MODEL.decl CASES.parquet ... -o kb.decl
        [--record record.json --train TRAIN.xes.gz ... --test TEST.xes.gz --prefixes P
        --max-suffix M]
        MODEL without the constraints that name an activity some cases artifact (a training
        log joined with the test log, `tleaf read-log`) has in none of its cases, and without
        those activities' `activity` and `bind` lines; the rest of the file byte for byte. The
        record (JSON) holds each dropped constraint, its line, the activities it names that the
        logs lack, which logs lack them and whether it holds on every case anyway (its formula
        checked on the cases, the absent activities never happening); and the prefix lengths
        and longest suffix the run uses beside the ones the data gives, each with where it
        came from; and which rows of their per-run CSV (--published) the report reads, refusing
        a CSV of several logs without --dataset before anything trains.
        pipelines/mezini_report.py shows it.
"""

from __future__ import annotations

import argparse
import csv
import gzip
import json
import math
import re
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path

# ---------------------------------------------------------------------------- settings

TRACE = re.compile(r"<trace\b.*?</trace>", re.DOTALL)
EVENT = re.compile(r"<event\b")


def case_lengths(path: Path) -> list[int]:
    """Events per trace of an XES log (.xes or .xes.gz), in file order."""
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", encoding="utf-8") as f:
        text = f.read()
    lengths = [len(EVENT.findall(m.group(0))) for m in TRACE.finditer(text)]
    if not lengths:
        raise SystemExit(f"{path}: no <trace> in it: not an XES log")
    return lengths


def derive(train: Sequence[Path], test: Path) -> dict:
    """The prefix lengths and the longest suffix their runner gives these logs, and why."""
    medians = {str(p): statistics.median(case_lengths(p)) for p in train}
    if len(set(medians.values())) > 1:
        raise SystemExit(
            "the training logs' median case lengths differ ("
            + ", ".join(f"{p}: {m:g}" for p, m in medians.items())
            + "): their noise relabels events and keeps every case's length; set PREFIXES="
        )
    median = next(iter(medians.values()))
    first = math.floor(median / 2)
    rule = (
        f"their runner's: floor(m / 2) and the next two, m = {median:g} the median length of "
        "the training cases"
    )
    if first < 1:  # eval needs a prefix of at least one event
        rule += f" (floor(m / 2) = {first}: raised to 1, the shortest prefix eval takes)"
        first = 1
    test_lengths = case_lengths(test)
    return {
        "prefixes": f"{first}-{first + 2}",
        "prefixes_rule": rule,
        "max_suffix": max(test_lengths),
        "max_suffix_rule": (
            f"the test log's longest case ({len(test_lengths)} cases): their sampler stops there"
        ),
    }


def settings_record(train: Sequence[Path], test: Path, prefixes: str, max_suffix: int) -> dict:
    """What the run used and what the data gives, each with where it came from."""
    data = derive(train, test)
    same_p, same_m = prefixes == data["prefixes"], max_suffix == data["max_suffix"]
    return {
        "prefixes": {
            "value": prefixes,
            "data": data["prefixes"],
            "from": data["prefixes_rule"] if same_p else "PREFIXES= (set by hand)",
        },
        "max_suffix": {
            "value": max_suffix,
            "data": data["max_suffix"],
            "from": data["max_suffix_rule"] if same_m else "MAX_SUFFIX= (set by hand)",
        },
        "logs": {"train": [str(p) for p in train], "test": str(test)},
    }


# ---------------------------------------------------------------------------- kb


def log_activities(cases: Sequence[Path]) -> dict[str, set[str]]:
    """Each cases artifact -> the activities its cases have (tleaf's reading of the log)."""
    from tleaf_cli.data.event_logs import read_cases

    out = {}
    for path in cases:
        out[str(path)] = {a for case in read_cases(path).cases for a in case.activities}
    return out


def sequences(cases: Sequence[Path]) -> set[tuple[str, ...]]:
    """The distinct activity sequences of every case of the artifacts."""
    from tleaf_cli.data.event_logs import read_cases

    return {tuple(case.activities) for p in cases for case in read_cases(p).cases}


def holds_everywhere(
    constraint, text: str, names: Sequence[str], traces: set[tuple[str, ...]]
) -> int | None:
    """How many of `traces` break the constraint's formula, every activity of `names` an atom
    (an activity no trace has never happens); None for a constraint with a condition on an
    attribute (`text`, its line, has one: the traces carry activities only) or one whose
    formula tleaf does not give."""
    if any(field.strip() for field in text.split("|")[1:]):
        return None
    from tleaf_cli.logic.checker import check
    from tleaf_cli.logic.compile import compile_formula

    atoms = {a: f"act{i}" for i, a in enumerate(names)}
    try:
        dfa = compile_formula(constraint.formula(atoms), "one-hot")
    except Exception:  # the reader's formula API, not its reading, is what this leans on
        return None
    ordered = sorted(traces)
    accepted = check(dfa, [[{atoms[a]} for a in t] for t in ordered if t])
    return int((~accepted).sum())


DECLARATION = re.compile(r"^(activity|bind)\s")
CONSTRAINT = re.compile(r"^[A-Za-z][\w -]*\[.*\]")


def constraint_lines(lines: list[str], constraints) -> list[int]:
    """The line number (from 1) of each constraint of the model read from `lines`: the
    constraint lines in file order, each checked to name the constraint's activities."""
    found = [
        number
        for number, text in enumerate(lines, start=1)
        if CONSTRAINT.match(text.strip()) and not DECLARATION.match(text.strip())
    ]
    if len(found) != len(constraints):
        raise SystemExit(
            f"{len(constraints)} constraints read, {len(found)} constraint lines found: "
            "a line this script does not recognise"
        )
    for number, c in zip(found, constraints, strict=True):
        head = lines[number - 1].split("|")[0]
        if not all(a in head for a in c.activities):
            raise SystemExit(f"line {number} does not name {', '.join(c.activities)}")
    return found


def kb(model_path: Path, cases: Sequence[Path], out: Path) -> dict:
    """Write the model without the constraints over activities a cases artifact lacks; return
    the record of what was dropped and why."""
    from tleaf_cli.knowledge.decl import read_decl

    model = read_decl(model_path)
    present = log_activities(cases)
    everywhere = set.intersection(*present.values())
    anywhere = set.union(*present.values())
    lines = model_path.read_text(encoding="utf-8").split("\n")
    names = sorted(
        set(model.activities) | anywhere | {a for c in model.constraints for a in c.activities}
    )
    traces = sequences(cases)
    numbers = constraint_lines(lines, model.constraints)
    dropped, drop_lines = [], set()
    for number, c in zip(numbers, model.constraints, strict=True):
        absent = [a for a in dict.fromkeys(c.activities) if a not in everywhere]
        if not absent:
            continue
        drop_lines.add(number)
        lacking = sorted({p for a in absent for p, acts in present.items() if a not in acts})
        in_none = all(a not in anywhere for a in absent)
        breaks = holds_everywhere(c, lines[number - 1], names, traces)
        why = (
            f"names {', '.join(absent)}, which "
            + (
                "no case of the training or test logs has"
                if in_none
                else f"the cases of {', '.join(lacking)} lack"
            )
            + ": "
            + (
                "not checked on the cases (a condition on an attribute, or no formula)"
                if breaks is None
                else f"it holds on every case anyway ({len(traces)} distinct traces), the "
                "activity never happening"
                if breaks == 0
                else f"it breaks {breaks} of the {len(traces)} distinct traces, the activity "
                "never happening: the model without it is looser than theirs"
            )
        )
        dropped.append(
            {
                "line": number,
                "constraint": lines[number - 1].split("|")[0].strip(),
                "absent": absent,
                "lacking": lacking,
                "breaks": breaks,
                "why": why,
            }
        )
    gone = {a for d in dropped for a in d["absent"]}
    still = {
        a
        for number, c in zip(numbers, model.constraints, strict=True)
        if number not in drop_lines
        for a in c.activities
    }
    unused = gone - still  # their declarations go with their constraints
    kept_lines = []
    for number, text in enumerate(lines, start=1):
        stripped = text.strip()
        if number in drop_lines:
            continue
        if any(stripped == f"activity {a}" or stripped.startswith(f"bind {a}:") for a in unused):
            continue
        kept_lines.append(text)
    out.write_text("\n".join(kept_lines), encoding="utf-8")
    return {
        "model": str(model_path),
        "kb": str(out),
        "constraints": len(model.constraints),
        "kept": len(model.constraints) - len(dropped),
        "dropped": dropped,
        "log_activities": {p: sorted(a) for p, a in present.items()},
    }


def published_rows(path: Path, dataset: str | None) -> dict:
    """Which rows of their per-run CSV the report will read (checked before any training: a
    CSV of several logs needs --dataset)."""
    with open(path, newline="") as f:
        logs = [r.get("dataset", "") for r in csv.DictReader(f)]
    names = sorted(set(logs))
    if dataset is None and len(names) > 1:
        raise SystemExit(
            f"{path}: rows of {len(names)} logs ({', '.join(names)}): set DATASET= to one"
        )
    if dataset is not None and dataset not in names:
        raise SystemExit(f"{path}: no rows of dataset {dataset!r} (it has {', '.join(names)})")
    chosen = dataset if dataset is not None else (names[0] if names else "")
    return {"csv": str(path), "dataset": chosen, "rows": logs.count(chosen)}


# ---------------------------------------------------------------------------- main


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    s = sub.add_parser("settings", help="print PREFIXES MAX_SUFFIX as their runner picks them")
    s.add_argument("train", type=Path, nargs="+", help="the training logs (XES)")
    s.add_argument("--test", type=Path, required=True, help="the test log (XES)")
    k = sub.add_parser("kb", help="the model without constraints over absent activities")
    k.add_argument("model", type=Path, help="the Declare model (.decl)")
    k.add_argument("cases", type=Path, nargs="+", help="the run's cases artifacts")
    k.add_argument("-o", "--out", type=Path, required=True)
    k.add_argument("--record", type=Path, help="the run's record (JSON)")
    k.add_argument("--train", type=Path, nargs="+", default=[], help="the training logs (XES)")
    k.add_argument("--test", type=Path, help="the test log (XES)")
    k.add_argument("--prefixes", help="the prefix lengths the run uses (PREFIXES)")
    k.add_argument("--max-suffix", type=int, help="the longest suffix it predicts (MAX_SUFFIX)")
    k.add_argument("--published", type=Path, help="their per-run CSV the report will read")
    k.add_argument("--dataset", help="its rows of this log (their `dataset` column)")
    args = parser.parse_args(argv)
    if args.command == "settings":
        got = derive(args.train, args.test)
        print(got["prefixes"], got["max_suffix"])
        return 0
    published = published_rows(args.published, args.dataset) if args.published else None
    record = kb(args.model, args.cases, args.out)
    for d in record["dropped"]:
        print(f"{args.out}: left out line {d['line']}, {d['constraint']}: {d['why']}")
    if args.record:
        if args.train and args.test and args.prefixes and args.max_suffix:
            record = {
                **settings_record(args.train, args.test, args.prefixes, args.max_suffix),
                "kb": record,
            }
        else:
            record = {"kb": record}
        if published:
            record["published"] = published
        args.record.write_text(json.dumps(record, indent=1, ensure_ascii=False) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
