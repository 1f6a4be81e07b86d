"""Declare4Py's MP-Declare conformance checking of an XES log against a `.decl` model, case by
case and constraint by constraint: the Declare4Py side of benchmarks/declare4py_conformance.py
and of tests/test_peer_agreement.py.

Runs in the peers' environment (.venv-peers, `bash run peers`; benchmarks/peers-requirements.txt)
and imports only Declare4Py and the pm4py it reads logs with, never tleaf:

    .venv-peers/bin/python benchmarks/peers/declare4py_check.py LOG.xes MODEL.decl OUT.json \\
        [--reader events|dataframe]

Declare4Py 2.2.0 (Donadello, Maggi, Riva; github.com/ivanDonadello/Declare4Py, which declares no
licence: no LICENSE file, no licence field in the wheel) parses the model (`DeclareModel`) and
checks each constraint on each trace with `MPDeclareAnalyzer(log, model, consider_vacuity=True)`:
a case that never activates a constraint satisfies it, as in LTLf. Its conditions are Python over
the event (`A.org:resource is not Value 3` is `"org:resource" in A and A["org:resource"] !=
"Value 3"`), so values compare as the log types them. How the log is read decides what an event
without the attribute is:

- `events` (the default): pm4py's own XES reading as an EventLog (`read_xes(...,
  return_legacy_log_object=True)`) handed to `D4PyEventLog(log=...)`: each event holds the
  attributes the XES gives it, typed as the XES types them (`<int>` an int, `<float>` a float),
  so an event without the attribute fails every test on it, the reading the conditions are
  written for (`"x" in A and ...`).
- `dataframe`: Declare4Py's `D4PyEventLog.parse_xes_log`, through pm4py's data frame: every
  event holds every attribute of the log, NaN where the XES gives it none (and an `<int>`
  attribute that some event lacks turns float), so an event without the attribute passes
  `is not`, `not in` and `!=` (NaN differs from everything) and fails the other tests.

Each constraint is checked on its own (a model of that constraint alone, as Declare4Py's own
`constraint_checking_with_support` does), so that one Declare4Py cannot check (a condition it
cannot parse, a value it cannot compare, a template without a checker) is reported with its
error and the others still are.

OUT.json: {"peer", "version", "reader", "constraints": Declare4Py's text of each constraint in the
model's order, "errors": per constraint null or the error, "cases": [{"case_id", "activities"}]
in the log's order, "satisfied": per case, per constraint true / false (null where it erred),
"seconds"}.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
import warnings
from importlib.metadata import version
from pathlib import Path


def read_log(path: Path, reader: str):
    """The log as Declare4Py's D4PyEventLog, read as `reader` says (see above)."""
    with contextlib.redirect_stdout(sys.stderr):  # pm4py's banner
        import pm4py
        from Declare4Py.D4PyEventLog import D4PyEventLog

    if reader == "dataframe":
        log = D4PyEventLog()
        log.parse_xes_log(str(path))
        return log
    return D4PyEventLog(log=pm4py.read_xes(str(path), return_legacy_log_object=True))


def check(log, path: Path) -> dict:
    """Every constraint of the model at `path` on every trace of `log`."""
    from Declare4Py.ProcessMiningTasks.ConformanceChecking.MPDeclareAnalyzer import (
        MPDeclareAnalyzer,
    )
    from Declare4Py.ProcessModels.DeclareModel import DeclareModel
    from Declare4Py.Utils.Declare.TraceStates import TraceState

    model = DeclareModel().parse_from_file(str(path))
    traces = list(log.get_log())
    satisfied: list[list[bool | None]] = [[] for _ in traces]
    errors: list[str | None] = []
    for j, constraint in enumerate(model.constraints):
        alone = DeclareModel()
        alone.constraints.append(constraint)
        alone.set_constraints()
        rows, error = None, None
        try:
            with contextlib.redirect_stdout(sys.stderr):  # its notes on unparsed conditions
                rows = MPDeclareAnalyzer(log, alone, consider_vacuity=True).run().model_check_res
            if any(len(row) != 1 or row[0] is None for row in rows):
                rows, error = None, "Declare4Py did not check it (a condition it could not parse?)"
        except Exception as failure:  # a peer's failure is a finding, reported per constraint
            error = f"{type(failure).__name__}: {failure}"
        errors.append(error)
        for i in range(len(traces)):
            satisfied[i].append(None if rows is None else rows[i][0].state == TraceState.SATISFIED)
        if error:
            print(f"constraint {j} ({model.serialized_constraints[j]}): {error}", file=sys.stderr)
    key = log.activity_key
    return {
        "constraints": list(model.serialized_constraints),
        "errors": errors,
        "cases": [
            {"case_id": str(t.attributes.get("concept:name")), "activities": [e[key] for e in t]}
            for t in traces
        ],
        "satisfied": satisfied,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", type=Path, help="an XES event log (.xes, .xes.gz)")
    parser.add_argument("model", type=Path, help="a Declare model (.decl)")
    parser.add_argument("out", type=Path, help="where the verdicts go (JSON)")
    parser.add_argument("--reader", choices=("events", "dataframe"), default="events")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore")  # pm4py's deprecation notes
    start = time.perf_counter()
    log = read_log(args.log, args.reader)
    result = check(log, args.model)
    result = {
        "peer": "declare4py",
        "version": version("declare4py"),
        "reader": args.reader,
        **result,
        "seconds": time.perf_counter() - start,
    }
    args.out.write_text(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
