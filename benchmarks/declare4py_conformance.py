"""tleaf's check-cases against Declare4Py's MP-Declare conformance checking, case by case and
constraint by constraint, on an XES log and Declare models (`.decl`) with conditions on event
attributes.

    bash run peers          # .venv-peers: Declare4Py 2.2.0 and pm4py, not tleaf dependencies
    .venv/bin/python benchmarks/declare4py_conformance.py LOG.xes MODEL.decl [MODEL.decl ...] \\
        --attributes org:resource [--reader events|dataframe]

Declare4Py (Donadello, Maggi, Riva; github.com/ivanDonadello/Declare4Py, version 2.2.0) is the
reference implementation of MP-Declare conformance checking. Its repository and its wheel declare
no licence (no LICENSE file, no licence field or classifier; its pyproject's `license = {text =
"GPL"}` is commented out), so it is used here as a peer only: installed in the peers' own
environment (.venv-peers, the versions pinned in benchmarks/peers-requirements.txt;
`--peers-python` or TLEAF_PEERS_PYTHON names another), never imported by tleaf, never
redistributed. It runs as a subprocess, benchmarks/peers/declare4py_check.py, which reads
the XES itself (pm4py's reader: `--reader`, that script's docstring) and checks every constraint
of each model on every trace with `MPDeclareAnalyzer` (vacuous satisfaction counted as
satisfaction, as in LTLf).

tleaf reads the same XES (`read_log` with `--attributes`, the cases of `tleaf read-log`) and
checks each constraint on its own (`read_case_rules` on the model's declarations and that one
constraint, then `check_cases`), so that a constraint tleaf refuses is reported with its reason
and the others are still compared. The two readings are matched by case id and their activity
sequences compared first (two log readers can differ: lifecycle filtering, time ties); then, per
constraint, the cases each says break it and the cases on which the two differ, with a few shown.
Exit status 0 when every constraint is checked by both and they agree on every case, 1 otherwise.
docs/event_logs.md has the results.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tleaf_cli.data.log_readers import read_log
from tleaf_cli.errors import InputError
from tleaf_cli.settings.event_logs import LogSettings
from tleaf_cli.tasks.case_checks import check_cases, read_case_rules

ROOT = Path(__file__).resolve().parent.parent
PEER = ROOT / "benchmarks" / "peers" / "declare4py_check.py"
EXAMPLES = 3
# a constraint line: a template name (RuM's, a count allowed) and its activities in brackets
CONSTRAINT = re.compile(r"^[A-Za-z][A-Za-z -]*\d*\[[^\]]*\]")


def peers_python(given: str | os.PathLike | None = None) -> Path:
    """The peers' python: `given`, else TLEAF_PEERS_PYTHON, else .venv-peers beside tleaf."""
    path = Path(given or os.environ.get("TLEAF_PEERS_PYTHON") or ROOT / ".venv-peers/bin/python")
    if not path.exists():
        raise SystemExit(f"no peers' python at {path}: run `bash run peers` (or name one)")
    return path


def split_decl(text: str) -> tuple[list[str], list[str]]:
    """A `.decl` model's declarations (activity, bind and domain lines, continuations included)
    and its constraint lines, each in file order."""
    declarations, constraints = [], []
    for line in text.splitlines():
        is_constraint = (
            CONSTRAINT.match(line) is not None
            and not line.startswith(("activity ", "bind "))
            and not line.startswith((" ", "\t"))
        )
        (constraints if is_constraint else declarations).append(line)
    return declarations, constraints


def run_declare4py(log: Path, model: Path, python: Path, folder: Path, reader: str) -> dict:
    """Declare4Py's check of every constraint of `model` on every trace of `log`, in the peers'
    environment: declare4py_check.py's OUT.json."""
    out = folder / f"{model.stem}.declare4py.json"
    command = [str(python), str(PEER), str(log), str(model), str(out), "--reader", reader]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{PEER.name} failed ({done.returncode}):\n{done.stderr[-4000:]}")
    return json.loads(out.read_text())


def tleaf_checks(cases, declarations: list[str], line: str, folder: Path) -> tuple:
    """tleaf's check of one constraint: (the rule's name, per case satisfied, None), or (None,
    None, the reason tleaf refused it)."""
    kb = folder / "constraint.decl"
    kb.write_text("\n".join([*declarations, line]) + "\n")
    try:
        rules = read_case_rules(kb)
        checks = check_cases(cases, rules)
    except InputError as refused:
        return None, None, str(refused).replace(str(kb), "the model")
    return rules[0].name, [bool(s) for s in checks.satisfied[:, 0]], None


def compare(
    log: Path,
    models: list[Path],
    attributes: tuple[str, ...],
    python: Path | None = None,
    reader: str = "events",
) -> dict:
    """The log and each model: both checks, case by case; the figures."""
    python = peers_python(python)
    cases = read_log(log, LogSettings(attributes=attributes or None))
    by_id = {case.case_id: i for i, case in enumerate(cases.cases)}
    out: dict = {"log": log.name, "cases": len(cases), "models": []}
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        for model in models:
            peer = run_declare4py(log, model, python, folder, reader)
            declarations, lines = split_decl(model.read_text())
            if len(lines) != len(peer["constraints"]):
                raise RuntimeError(
                    f"{model}: {len(lines)} constraint lines, Declare4Py read "
                    f"{len(peer['constraints'])}: {peer['constraints']}"
                )
            peer_ids = [c["case_id"] for c in peer["cases"]]
            # Declare4Py's case -> tleaf's, and the cases the two readers read alike
            pairs = [(k, by_id[c]) for k, c in enumerate(peer_ids) if c in by_id]
            alike = [
                (k, i)
                for k, i in pairs
                if peer["cases"][k]["activities"] == list(cases.cases[i].activities)
            ]
            found = {
                "model": model.name,
                "declare4py": peer["version"],
                "reader": peer["reader"],
                "peer_cases": len(peer_ids),
                "matched": len(pairs),
                "alike": len(alike),
                "peer_seconds": peer["seconds"],
                "constraints": [],
            }
            for j, line in enumerate(lines):
                start = time.perf_counter()
                rule, kept, refused = tleaf_checks(cases, declarations, line, folder)
                row: dict = {
                    "constraint": line.strip(),
                    "rule": rule,
                    "tleaf_refused": refused,
                    "declare4py_error": peer["errors"][j],
                    "tleaf_seconds": time.perf_counter() - start,
                }
                if kept is not None and peer["errors"][j] is None:
                    d4 = {i: peer["satisfied"][k][j] for k, i in alike}
                    row["tleaf_broken"] = sum(not kept[i] for i in d4)
                    row["declare4py_broken"] = sum(not s for s in d4.values())
                    row["differ"] = [
                        (cases.cases[i].case_id, kept[i], s) for i, s in d4.items() if kept[i] != s
                    ]
                found["constraints"].append(row)
            out["models"].append(found)
    return out


def agree(r: dict) -> bool:
    """Every constraint checked by both, the same verdict on every case read alike, every case
    read alike."""
    return all(
        m["alike"] == r["cases"] == m["peer_cases"]
        and all("differ" in c and not c["differ"] for c in m["constraints"])
        for m in r["models"]
    )


def report(r: dict) -> None:
    """The figures, as printed lines."""
    for m in r["models"]:
        print(
            f"\n== {r['log']} ({r['cases']} cases) against {m['model']}: Declare4Py "
            f"{m['declare4py']} (reader {m['reader']}, {m['peer_seconds']:.1f} s) read "
            f"{m['peer_cases']} cases, {m['matched']} matched by id, {m['alike']} with the same "
            f"activities"
        )
        for c in m["constraints"]:
            print(f"   {c['constraint']}")
            if c["tleaf_refused"] is not None:
                print(f"      tleaf refused: {c['tleaf_refused']}")
            if c["declare4py_error"] is not None:
                print(f"      Declare4Py failed: {c['declare4py_error']}")
            if "differ" not in c:
                continue
            print(
                f"      broken by {c['tleaf_broken']} cases (tleaf, {c['rule']}, "
                f"{c['tleaf_seconds']:.1f} s), {c['declare4py_broken']} (Declare4Py); "
                f"cases that differ: {len(c['differ'])}"
            )
            for case_id, tl, d4 in c["differ"][:EXAMPLES]:
                print(
                    f"      case {case_id}: tleaf {'satisfied' if tl else 'violated'}, "
                    f"Declare4Py {'satisfied' if d4 else 'violated'}"
                )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", type=Path, help="an XES event log (.xes, .xes.gz)")
    parser.add_argument("models", nargs="+", type=Path, help="Declare models (.decl)")
    parser.add_argument(
        "--attributes",
        default="",
        help="the event attributes the conditions read, comma-separated (read-log --attributes)",
    )
    parser.add_argument(
        "--reader",
        choices=("events", "dataframe"),
        default="events",
        help="how Declare4Py reads the XES (benchmarks/peers/declare4py_check.py)",
    )
    parser.add_argument(
        "--peers-python",
        type=Path,
        default=None,
        help="the peers' python (default: TLEAF_PEERS_PYTHON, else .venv-peers/bin/python)",
    )
    args = parser.parse_args(argv)
    attributes = tuple(a.strip() for a in args.attributes.split(",") if a.strip())
    r = compare(args.log, args.models, attributes, args.peers_python, args.reader)
    report(r)
    return 0 if agree(r) else 1


if __name__ == "__main__":
    sys.exit(main())
