"""pm4py's Declare discovery and conformance checking on cases handed over as JSON: the pm4py side
of benchmarks/pm4py_conformance.py and of tests/test_check_cases.py's agreement test.

Runs in the peers' environment (.venv-peers, `bash run peers`; benchmarks/peers-requirements.txt)
and imports only pm4py (AGPL-3.0, never a tleaf dependency), never tleaf:

    .venv-peers/bin/python benchmarks/peers/pm4py_declare.py CASES.json OUT.json [--min-support S]
    .venv-peers/bin/python benchmarks/peers/pm4py_declare.py CASES.json OUT.json --model MODEL.json

CASES.json, written by the tleaf side: {"cases": [{"case_id", "activities", "timestamps"}, ...]},
the cases in tleaf's order, timestamps in ISO 8601. They become pm4py's EventLog as they are (one
trace per case, `concept:name` its id, its events in that order), so that two checkers, not two
log readers, are compared. pm4py discovers a model of its 18 templates (`discover_declare`, its
automatic support and confidence, or `--min-support`), or checks the constraints of MODEL.json
(a list of [template, activity or [activities]]), and checks every case (`conformance_declare`).

OUT.json: {"peer", "version", "constraints": [[template, activity or [activities]], ...] in
pm4py's order, "violated": per case in CASES.json's order the indices of the constraints pm4py
reports as deviations, "seconds": discovery and check}.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
import warnings
from datetime import datetime
from pathlib import Path

# pm4py's 18 Declare templates, all allowed in discovery
TEMPLATES = (
    *("existence", "exactly_one", "init", "responded_existence", "response", "precedence"),
    *("succession", "altresponse", "altprecedence", "altsuccession", "chainresponse"),
    *("chainprecedence", "chainsuccession", "absence", "coexistence", "noncoexistence"),
    *("nonsuccession", "nonchainsuccession"),
)


def event_log(cases: list[dict]):
    """The cases as pm4py's EventLog, in their order, each event its activity and timestamp."""
    from pm4py.objects.log.obj import Event, EventLog, Trace

    traces = []
    for case in cases:
        trace = Trace(attributes={"concept:name": case["case_id"]})
        for activity, stamp in zip(case["activities"], case["timestamps"], strict=True):
            trace.append(
                Event({"concept:name": activity, "time:timestamp": datetime.fromisoformat(stamp)})
            )
        traces.append(trace)
    return EventLog(traces)


def key(template: str, acts: object) -> tuple[str, object]:
    """A constraint's identity: its template and activity, or its activities as a tuple."""
    return template, acts if isinstance(acts, str) else tuple(acts)


def run(cases: list[dict], min_support: float | None, given: list | None) -> dict:
    """Discover (or take) the model, check every case; the figures OUT.json holds."""
    with contextlib.redirect_stdout(sys.stderr):  # pm4py's banner
        import pm4py

    log = event_log(cases)
    start = time.perf_counter()
    if given is None:
        model = pm4py.discover_declare(
            log, allowed_templates=set(TEMPLATES), min_support_ratio=min_support
        )
    else:
        model: dict = {}
        for template, acts in given:
            name, k = key(template, acts)
            model.setdefault(name, {})[k] = {"support": 1.0, "confidence": 1.0}
    results = pm4py.conformance_declare(log, model)
    seconds = time.perf_counter() - start
    constraints = [key(t, a) for t, found in model.items() for a in found]
    index = {c: j for j, c in enumerate(constraints)}
    violated = [sorted(index[key(t, a)] for t, a in r["deviations"]) for r in results]
    return {
        "peer": "pm4py",
        "version": pm4py.__version__,
        "constraints": [[t, a if isinstance(a, str) else list(a)] for t, a in constraints],
        "violated": violated,
        "seconds": seconds,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("cases", type=Path, help="the cases, JSON, written by the tleaf side")
    parser.add_argument("out", type=Path, help="where the verdicts go (JSON)")
    parser.add_argument("--min-support", type=float, default=None)
    parser.add_argument("--model", type=Path, default=None, help="constraints to check (JSON)")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore")  # pm4py's deprecation notes on EventLog objects
    cases = json.loads(args.cases.read_text())["cases"]
    given = None if args.model is None else json.loads(args.model.read_text())
    args.out.write_text(json.dumps(run(cases, args.min_support, given)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
