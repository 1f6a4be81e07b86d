"""A log's own XES cases under Rama-Maneiro et al.'s case ids, so that `split-cases --folds 5`
gives the benchmark's very folds while the model reads the attributes their CSV dropped.

    python pipelines/rm_case_ids.py XES_CASES CSV_CASES -o OUT.parquet

XES_CASES: `tleaf read-log` of the log's XES, keeping its attributes; CSV_CASES: `tleaf read-
log` of the benchmark's preprocessed CSV (CaseID, ActivityID, CompleteTimestamp: the same cases
with ids and activities renumbered, times to the second). A CSV case is matched to the XES case
with the same number of events, the same minute and second of its first event and the same gaps
between events, in whole seconds. Cases that key leaves ambiguous (short cases starting in the
same minute and second of different hours) are then told apart by their absolute start, shifted
by the one time-zone offset the unambiguous matches agree on, and by their activities, named by
those matches. The matches must be one to one and every CSV activity id must name one XES
activity throughout, or nothing is written. A CSV case no XES case matches (where
the benchmark's preprocessing dropped events) is kept as the CSV has it, its activities named,
without attribute values: the cases, and so the folds, are the benchmark's. Prints the counts.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter, defaultdict
from dataclasses import replace
from itertools import pairwise
from pathlib import Path

from tleaf_cli.data.artifacts import describe_inputs
from tleaf_cli.data.event_logs import Case, read_cases, write_case_table


def key(case: Case) -> tuple:
    """What identifies a case whatever its id and activity names (time zones shift hours)."""
    seconds = [int(t.timestamp()) for t in case.timestamps]  # the CSV drops milliseconds
    gaps = tuple(b - a for a, b in pairwise(seconds))
    return (len(case), seconds[0] % 3600, gaps)


def start(case: Case) -> int:
    """The case's first event, in whole seconds since the epoch."""
    return int(case.timestamps[0].timestamp())


def renamed(xes_path: Path, csv_path: Path) -> tuple[list[Case], dict, Counter]:
    """The CSV's cases, each the XES case it matches (under the CSV's id), or its own events
    with the XES activity names; the XES activity -> atom map; the counts."""
    xes, csv = read_cases(xes_path), read_cases(csv_path)
    by_key: dict[tuple, list[Case]] = defaultdict(list)
    for c in xes.cases:
        by_key[key(c)].append(c)
    csv_keys = Counter(key(c) for c in csv.cases)
    names: dict[str, Counter] = defaultdict(Counter)
    matched: dict[str, Case] = {}
    for c in csv.cases:
        k = key(c)
        if len(by_key.get(k, ())) == 1 and csv_keys[k] == 1:
            match = by_key[k][0]
            matched[c.case_id] = match
            for a, b in zip(c.activities, match.activities, strict=True):
                names[a][b] += 1
    clash = [a for a, n in names.items() if len(n) > 1]
    if clash:
        sys.exit(f"error: CSV activity {clash[0]!r} matches XES activities {dict(names[clash[0]])}")
    name = {a: next(iter(n)) for a, n in names.items()}
    counts: Counter = Counter(xes=len(xes.cases), csv=len(csv.cases), matched=len(matched))
    csv_case = {c.case_id: c for c in csv.cases}
    offsets = {start(csv_case[i]) - start(x) for i, x in matched.items()}
    if len(offsets) == 1:  # one time-zone shift: the absolute start tells the rest apart
        (offset,) = offsets
        taken = {x.case_id for x in matched.values()}
        by_start: dict[tuple, list[Case]] = defaultdict(list)
        for x in xes.cases:
            if x.case_id not in taken:
                by_start[(key(x), start(x) + offset, x.activities)].append(x)
        rest = [c for c in csv.cases if c.case_id not in matched]
        if all(a in name for c in rest for a in c.activities):
            refined = {
                c.case_id: (key(c), start(c), tuple(name[a] for a in c.activities)) for c in rest
            }
            claims = Counter(refined.values())
            for c in rest:
                k = refined[c.case_id]
                if len(by_start.get(k, ())) == 1 and claims[k] == 1:
                    matched[c.case_id] = by_start[k][0]
                    counts["matched by their start"] += 1
        counts["matched"] = len(matched)
    out = []
    for c in csv.cases:
        if c.case_id in matched:
            out.append(replace(matched[c.case_id], case_id=c.case_id))
            continue
        unnamed = [a for a in c.activities if a not in name]
        if unnamed:
            sys.exit(f"error: case {c.case_id}: activity {unnamed[0]!r} matches no XES activity")
        acts = tuple(name[a] for a in c.activities)
        out.append(
            replace(
                c,
                activities=acts,
                atoms=tuple(xes.activity_atoms[a] for a in acts),
                attributes={n: (None,) * len(c) for n in xes.attribute_names},
                case_attributes=dict.fromkeys(xes.case_attribute_names),
            )
        )
        counts["kept from the CSV"] += 1
    return out, xes.activity_atoms, counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("xes", type=Path)
    parser.add_argument("csv", type=Path)
    parser.add_argument("-o", "--out", type=Path, required=True)
    args = parser.parse_args()
    cases, atoms, counts = renamed(args.xes, args.csv)
    params = {"matched_from": str(args.xes), "case_ids_of": str(args.csv), **counts}
    write_case_table(cases, atoms, args.out, params, describe_inputs([args.xes, args.csv]))
    print(f"{args.out}: " + ", ".join(f"{k} {v}" for k, v in counts.items()))


if __name__ == "__main__":
    main()
