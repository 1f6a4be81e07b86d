"""`tleaf inspect`: any artifact's provenance and first rows; one DFA's states and edges."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from tleaf_cli import ui
from tleaf_cli.data.activity_names import folded
from tleaf_cli.data.artifacts import read_provenance
from tleaf_cli.data.dfa_table import KIND as DFA_KIND
from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.data.event_logs import ATOMS_KEY, CASE_PREFIX, EVENT_PREFIX
from tleaf_cli.data.event_logs import KIND as CASES_KIND
from tleaf_cli.data.graphs import render_dot, row_to_dot
from tleaf_cli.errors import InputError

CELL_CHARS = 60
TOP_ACTIVITIES = 10  # the most frequent activities a cases artifact's --stats lists
TOP_VALUES = 5  # the most frequent values of each kept attribute it lists
MAP_ROWS = 40  # the activity name -> atom pairs inspect lists
PREDICTIONS_KIND = "predictions"  # tleaf predict's (tasks/next_activity/predictions.py)
ACTION_PREDICTIONS_KIND = "action_predictions"  # on action-recognition runs (its predict.py)


def show_artifact(path: Path, limit: int = 10) -> None:
    """Kind, schema, version, params, inputs, columns and the first `limit` rows."""
    prov = read_provenance(path)
    with _reading(path):  # all of it before printing: a damaged file prints only its error
        parquet = pq.ParquetFile(path)
        n_rows = parquet.metadata.num_rows
        schema = parquet.schema_arrow
        head = next(parquet.iter_batches(batch_size=max(limit, 1)), None)
        rows = head.to_pylist()[:limit] if head is not None else []
        compiled = None
        if prov.kind == DFA_KIND and n_rows:
            compiled = pq.read_table(path, columns=["error"]).column("error").null_count
    ui.text(f"{path}: {prov.kind} artifact, schema {prov.schema}, tleaf {prov.version}")
    ui.text(f"rows: {n_rows}")
    ui.text(f"params: {json.dumps(prov.params, sort_keys=True)}")
    for item in prov.inputs:
        ui.text(f"input: {item.get('path')} (sha256 {str(item.get('sha256'))[:12]}…)")
    ui.text("columns: " + ", ".join(f"{f.name} {f.type}" for f in schema))
    if prov.kind == DFA_KIND:
        rows = [_dfa_brief(r) for r in rows]
    if prov.kind == PREDICTIONS_KIND:
        rows = [_prediction_brief(r) for r in rows]
    if prov.kind == ACTION_PREDICTIONS_KIND:
        rows = [_action_prediction_brief(r) for r in rows]
    if rows:
        columns = list(rows[0])
        ui.table(f"first {len(rows)} rows", columns, [[_cell(r[c]) for c in columns] for r in rows])
    if compiled is not None:
        ui.text(f"compiled: {compiled} of {n_rows}; failed: {n_rows - compiled}")
    if prov.kind == CASES_KIND:
        _show_activity_atoms(schema)


def _show_activity_atoms(schema: pa.Schema) -> None:
    """A cases artifact's activity name -> atom map (the one every reader of rules for the log
    uses): the names that read as one word first, then the others, up to MAP_ROWS rows."""
    raw = (schema.metadata or {}).get(ATOMS_KEY.encode())
    if raw is None:
        return
    atoms = json.loads(raw)
    groups = folded(atoms)
    first = [n for names in groups for n in names]
    order = first + sorted(n for n in atoms if n not in set(first))
    rows = [[ui.visible(n), atoms[n]] for n in order[:MAP_ROWS]]
    more = f", first {MAP_ROWS}" if len(order) > MAP_ROWS else ""
    ui.table(
        f"activity atoms ({len(atoms)} names{more}; {len(groups)} groups told apart)",
        ["activity", "atom"],
        rows,
    )


def show_stats(path: Path) -> None:
    """Distributions: DFA sizes for a dfas.parquet; labels, sources, splits, lengths for traces;
    splits, events, case lengths, variants and the most frequent activities for cases."""
    prov = read_provenance(path)
    with _reading(path):
        table = pq.read_table(path)
    ui.text(f"{path}: {prov.kind} artifact, {table.num_rows} rows")
    if prov.kind == DFA_KIND:
        rows = [r for r in table.select(["num_states", "edges", "error"]).to_pylist()]
        ok = [r for r in rows if r["error"] is None]
        ui.text(f"compiled {len(ok)}, failed {len(rows) - len(ok)}")
        if ok:
            states = Counter(r["num_states"] for r in ok)
            edges = [len(r["edges"]) for r in ok]
            ui.text(f"edges per DFA: mean {sum(edges) / len(edges):.1f}, max {max(edges)}")
            ui.table(
                "DFA states",
                ["states", "DFAs", "share"],
                [[str(k), str(v), f"{v / len(ok):.1%}"] for k, v in sorted(states.items())],
            )
    elif prov.kind == "traces":
        rows = table.drop_columns(["trace"]).to_pylist()
        lengths = [len(t) for t in table.column("trace").to_pylist()]
        for column in ("label", "source", "split"):
            if column in table.column_names:
                counts = Counter(str(r[column]) for r in rows)
                ui.text(f"{column}: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
        by_label = {True: Counter(), False: Counter()}
        for r, n in zip(rows, lengths, strict=True):
            by_label[r["label"]][n] += 1
        keys = sorted(set(lengths))
        ui.table(
            "trace lengths",
            ["length", "satisfying", "violating"],
            [[str(k), str(by_label[True][k]), str(by_label[False][k])] for k in keys],
        )
    elif prov.kind == CASES_KIND:
        _show_cases_stats(table)
    else:
        ui.text("(no statistics for this kind)")


def _show_cases_stats(table: pa.Table) -> None:
    """An event log's figures as process mining reports them: cases per split, events,
    activities, variants (distinct activity sequences), case length min / median / max, and the
    most frequent activities with their share of events and of cases."""
    sequences = [tuple(a) for a in table.column("activities").to_pylist()]
    splits = Counter(table.column("split").to_pylist())
    shown = ("train", "val", "test", *sorted(set(splits) - {"train", "val", "test"}))  # unused
    ui.text("cases: " + ", ".join(f"{k} {splits.get(k, 0)}" for k in shown))
    lengths = sorted(len(s) for s in sequences)
    events = sum(lengths)
    counts = Counter(a for s in sequences for a in s)
    ui.text(f"events: {events}; activities: {len(counts)}; variants: {len(set(sequences))}")
    if not lengths:
        return
    ui.text(
        f"case length: min {lengths[0]}, median {_median(lengths):g}, max {lengths[-1]}, "
        f"mean {events / len(lengths):.1f}"
    )
    in_cases = Counter(a for s in sequences for a in set(s))
    top = counts.most_common(TOP_ACTIVITIES)
    ui.table(
        f"{len(top)} most frequent activities of {len(counts)}",
        ["activity", "events", "share of events", "cases", "share of cases"],
        [
            [a, str(n), f"{n / events:.1%}", str(in_cases[a]), f"{in_cases[a] / len(lengths):.1%}"]
            for a, n in top
        ],
    )
    _show_attribute_stats(table)


def _show_attribute_stats(table: pa.Table) -> None:
    """Each kept attribute (`read-log --attributes`, `--case-attributes`): how many events (or
    cases) have a value, its distinct values, and the most frequent ones with their counts."""
    for column in table.column_names:
        if column.startswith(EVENT_PREFIX):
            values = [v for vs in table.column(column).to_pylist() for v in vs]
            what, name = "events", column[len(EVENT_PREFIX) :]
        elif column.startswith(CASE_PREFIX):
            values = table.column(column).to_pylist()
            what, name = "cases", f"case attribute {column[len(CASE_PREFIX) :]}"
        else:
            continue
        counts = Counter(v for v in values if v is not None)
        held = sum(counts.values())
        top = ", ".join(f"{v} ({n})" for v, n in counts.most_common(TOP_VALUES))
        ui.text(
            f"{name}: {len(counts)} distinct values, on {held} of {len(values)} {what}"
            + (f"; most frequent: {top}" if top else "")
        )


def _median(ordered: list[int]) -> float:
    """The median of sorted numbers (the mean of the middle two for an even count)."""
    mid = len(ordered) // 2
    return ordered[mid] if len(ordered) % 2 else (ordered[mid - 1] + ordered[mid]) / 2


def show_dfa(path: Path, formula_id: str, dot: bool = False, draw: Path | None = None) -> None:
    """One DFA: states (initial/accepting) and guarded edges; or its DOT text, a drawing, or
    both (drawn first, so a failing Graphviz prints nothing)."""
    table = read_dfas(path)
    row = table.row(formula_id)
    if row["error"] is not None:
        ui.text(f"{formula_id}: {row['formula']}")
        ui.text(f"did not compile: {row['error']}")
        return
    if draw is not None:
        render_dot(row_to_dot(row), draw)
    if dot:
        ui.text(row_to_dot(row).rstrip("\n"))
    if draw is not None:
        ui.summary(f"drew {formula_id} to {draw}")
    if dot or draw is not None:
        return
    ui.text(f"{formula_id}: {row['formula']}")
    ui.text(f"atoms: {' '.join(row['atoms']) or '(none)'}   alphabet: {row['alphabet']}")
    accepting = set(row["accepting"])
    states = [
        [str(s), "yes" if s == row["initial"] else "", "yes" if s in accepting else ""]
        for s in range(row["num_states"])
    ]
    ui.table(f"{row['num_states']} states", ["state", "initial", "accepting"], states)
    edges = [[str(e["src"]), str(e["dst"]), e["guard"], json.dumps(e["cnf"])] for e in row["edges"]]
    ui.table(f"{len(edges)} edges", ["src", "dst", "guard", "cnf"], edges)


@contextmanager
def _reading(path: Path) -> Iterator[None]:
    """InputError naming the file, on one line, when its data cannot be read: a damaged or cut
    file whose footer still reads fails only here, and Arrow's message names no file."""
    try:
        yield
    except (pa.ArrowException, OSError) as e:
        detail = (str(e).strip().splitlines() or [e.__class__.__name__])[0]
        raise InputError(f"{path}: unreadable ({detail})") from None


def _dfa_brief(row: dict) -> dict:
    """A dfas.parquet row with edges summarised, so the table stays readable."""
    return {
        "formula_id": row["formula_id"],
        "formula": row["formula"],
        "atoms": None if row["atoms"] is None else " ".join(row["atoms"]),
        "states": row["num_states"],
        "accepting": row["accepting"],
        "edges": None if row["edges"] is None else len(row["edges"]),
        "error": row["error"],
    }


def _prediction_brief(row: dict) -> dict:
    """A predictions row in a few words: the next activity, the suffix, each rule's verdict and
    probability of holding (P permanently / T temporarily, + satisfied / − violated), the
    recommendation (the columns: docs/monitoring.md)."""
    signs = {"permanently satisfied": "P+", "temporarily satisfied": "T+",
             "temporarily violated": "T-", "permanently violated": "P-"}  # fmt: skip
    top = (row.get("next_activities") or [None])[0]
    rules = [
        f"{r['rule']} {signs.get(r['verdict'], '?')}"
        + ("" if r["probability"] is None else f" {r['probability']:.2f}")
        for r in row.get("rules") or []
    ]
    advice = row.get("recommendation")
    return {
        "case_id": row.get("case_id"),
        "k": row.get("prefix_length"),
        "next": row.get("reason")
        if top is None
        else f"{top['activity']} ({top['probability']:.2f})",
        "end": None if row.get("end_probability") is None else round(row["end_probability"], 3),
        "suffix": None if row.get("suffix") is None else " ".join(row["suffix"]) or "(end)",
        "rules (p holds)": "; ".join(rules) or None,
        "recommendation": row.get("recommendation_status") if not advice else " ".join(advice),
    }


def _action_prediction_brief(row: dict) -> dict:
    """An action_predictions row in a few words: the argmax pair with each head's probability,
    the pair under the rules with its probability, the label, and per video the rules the
    argmax labels break and whether the labels under the rules keep theirs (the columns:
    docs/monitoring.md)."""
    broken = row.get("argmax_broken") or []
    kept = not row.get("constrained_broken")
    return {
        "video_id": row.get("video_id"),
        "step": row.get("step"),
        "argmax (p action, p ingredient)": f"{row['action']}_{row['ingredient']} "
        f"({row['action_probability']:.2f}, {row['ingredient_probability']:.2f})",
        "under the rules (p)": f"{row['constrained_action']}_{row['constrained_ingredient']} "
        f"({row['constrained_probability']:.2f})",
        "label": None
        if row.get("true_action") is None
        else f"{row['true_action']}_{row.get('true_ingredient')}",
        "argmax breaks": f"{len(broken)} of {row.get('argmax_rules')}: {', '.join(broken)}"
        if broken
        else f"none of {row.get('argmax_rules')}",
        "rules keep": f"all {row.get('constrained_rules')}" if kept else "no",
    }


def _cell(value) -> str:
    if value is None:
        return "—"
    # default=str: a cases artifact's timestamps (datetime) as ISO text
    text = value if isinstance(value, str) else json.dumps(value, default=str)
    return text if len(text) <= CELL_CHARS else text[: CELL_CHARS - 1] + "…"
