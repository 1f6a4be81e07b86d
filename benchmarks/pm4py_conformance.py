"""tleaf's check-cases against pm4py's `conformance_declare`, the field's reference, case by case.

For each log: the cases as `tleaf read-log` reads them; a Declare model of pm4py's 18 templates
discovered by pm4py (`discover_declare`, its default automatic support and confidence, or
`--min-support`) on those same cases; each discovered constraint written as a tleaf rule with
knowledge/templates.py (pm4py's template name -> tleaf's key, its activities -> their atoms);
tleaf's exact check (tasks/case_checks.py, the code behind `tleaf check-cases`) and pm4py's on
every case. Prints, per log, the cases whose violation counts agree, every (case, constraint)
on which the two differ counted by template, and the first few with the case's activities.

    bash run peers                                # .venv-peers: pm4py (AGPL), not tleaf's
    .venv/bin/python benchmarks/pm4py_conformance.py LOG [LOG ...] [--min-support 0.5]

pm4py runs in the peers' own environment (.venv-peers, the versions pinned in
benchmarks/peers-requirements.txt; `--peers-python` or TLEAF_PEERS_PYTHON names another), as a
subprocess: benchmarks/peers/pm4py_declare.py, which imports pm4py only. The comparison reads the
log once, with tleaf, and hands pm4py those cases (JSON: one case per trace, events in tleaf's
order), which it makes its own EventLog, so that the two checkers, not two log readers
(lifecycle filtering, time ties), are compared. docs/event_logs.md has the results and why
pm4py's reading differs where it does.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

from tleaf_cli.data.cases import Cases
from tleaf_cli.data.log_readers import read_log
from tleaf_cli.knowledge.templates import find_template
from tleaf_cli.settings.event_logs import LogSettings
from tleaf_cli.tasks.case_checks import check_cases, read_case_rules

# pm4py's 18 template names -> tleaf's template (templates.py) and count
PM4PY_TEMPLATES: dict[str, tuple[str, int]] = {
    "existence": ("existence", 1),
    "exactly_one": ("exactly", 1),
    "init": ("init", 1),
    "responded_existence": ("responded_existence", 1),
    "response": ("response", 1),
    "precedence": ("precedence", 1),
    "succession": ("succession", 1),
    "altresponse": ("alternate_response", 1),
    "altprecedence": ("alternate_precedence", 1),
    "altsuccession": ("alternate_succession", 1),
    "chainresponse": ("chain_response", 1),
    "chainprecedence": ("chain_precedence", 1),
    "chainsuccession": ("chain_succession", 1),
    "absence": ("absence", 1),
    "coexistence": ("co_existence", 1),
    "noncoexistence": ("not_co_existence", 1),
    "nonsuccession": ("not_succession", 1),
    "nonchainsuccession": ("not_chain_succession", 1),
}
# pm4py's own definitions of these two are not Declare's (docs/event_logs.md, check-cases):
# nonsuccession(a, b) is violated where succession(a, b) holds with both present, Declare's Not
# Succession where some b follows some a; likewise nonchainsuccession and Not Chain Succession.
NOT_DECLARE = ("nonsuccession", "nonchainsuccession")
EXAMPLES = 5
ROOT = Path(__file__).resolve().parent.parent
PEER = ROOT / "benchmarks" / "peers" / "pm4py_declare.py"


def peers_python(given: str | os.PathLike | None = None) -> Path:
    """The peers' python: `given`, else TLEAF_PEERS_PYTHON, else .venv-peers beside tleaf."""
    path = Path(given or os.environ.get("TLEAF_PEERS_PYTHON") or ROOT / ".venv-peers/bin/python")
    if not path.exists():
        raise SystemExit(f"no peers' python at {path}: run `bash run peers` (or name one)")
    return path


def cases_json(cases: Cases) -> dict:
    """The cases as pm4py_declare.py reads them: each its id, activities and ISO timestamps,
    in tleaf's order."""
    return {
        "cases": [
            {
                "case_id": case.case_id,
                "activities": list(case.activities),
                "timestamps": [stamp.isoformat() for stamp in case.timestamps],
            }
            for case in cases.cases
        ]
    }


def run_pm4py(cases: Cases, min_support: float | None, python: Path, folder: Path) -> dict:
    """pm4py's discovery and check of `cases`, in the peers' environment: pm4py_declare.py's
    OUT.json."""
    given, out = folder / "cases.json", folder / "pm4py.json"
    given.write_text(json.dumps(cases_json(cases)))
    command = [str(python), str(PEER), str(given), str(out)]
    if min_support is not None:
        command += ["--min-support", repr(min_support)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{PEER.name} failed ({done.returncode}):\n{done.stderr[-4000:]}")
    return json.loads(out.read_text())


def model_rules(model: dict, atoms: dict[str, str]) -> tuple[str, list[tuple[str, object]]]:
    """The discovered model as a `.ltl` text, one named rule per constraint, and the (pm4py
    template, activities) of each rule in order."""
    lines, keys = [], []
    for pm_name, constraints in model.items():
        key, n = PM4PY_TEMPLATES[pm_name]
        template, _ = find_template(key)
        for k, acts in enumerate(constraints):
            pair = (acts,) if isinstance(acts, str) else tuple(acts)
            formula = template.ltlf(*(atoms[a] for a in pair), n=n)
            lines.append(f"{pm_name}.{k}: {formula}")
            keys.append((pm_name, acts))
    return "\n".join(lines) + "\n", keys


def compare(path: Path, min_support: float | None, python: Path | None = None) -> dict:
    """One log: discover with pm4py, check with both, compare; the figures."""
    cases = read_log(path, LogSettings())
    with tempfile.TemporaryDirectory() as folder:
        pm = run_pm4py(cases, min_support, peers_python(python), Path(folder))
        model: dict = {}
        for template, acts in pm["constraints"]:
            model.setdefault(template, []).append(acts if isinstance(acts, str) else tuple(acts))
        text, keys = model_rules(model, cases.activity_atoms)
        pm_seconds = pm["seconds"]
        kb = Path(folder) / "model.ltl"
        kb.write_text(text)
        start = time.perf_counter()
        checks = check_cases(cases, read_case_rules(kb))
        tleaf_seconds = time.perf_counter() - start
    pm_broken = np.zeros_like(checks.satisfied)
    for i, violated in enumerate(pm["violated"]):
        pm_broken[i, violated] = True
    tl_broken = ~checks.satisfied
    differ = pm_broken != tl_broken
    by_template = Counter(keys[j][0] for _, j in zip(*np.nonzero(differ), strict=True))
    kept = np.array([t not in NOT_DECLARE for t, _ in keys], dtype=bool)
    direct = sum(
        declare_violates(t, tuple(acts), case.activities) != bool(tl_broken[i, j])
        for j, (t, acts) in enumerate(keys)
        if t in NOT_DECLARE
        for i, case in enumerate(cases.cases)
    )
    examples = [
        (cases.cases[i], keys[j], bool(pm_broken[i, j]), bool(tl_broken[i, j]))
        for i, j in zip(*np.nonzero(differ), strict=True)
    ]
    return {
        "log": path.name,
        "cases": len(cases),
        "constraints": len(keys),
        "per_template": Counter(t for t, _ in keys),
        "agree": int((pm_broken.sum(1) == tl_broken.sum(1)).sum()),
        "agree_declare": int((pm_broken[:, kept].sum(1) == tl_broken[:, kept].sum(1)).sum()),
        "declare_constraints": int(kept.sum()),
        "differ_pairs": int(differ.sum()),
        "only_pm4py": int((pm_broken & ~tl_broken).sum()),  # violated by pm4py only
        "only_tleaf": int((tl_broken & ~pm_broken).sum()),
        "direct_differ": direct,
        "by_template": by_template,
        "examples": examples,
        "seconds": (pm_seconds, tleaf_seconds),
        "alphabet": checks.alphabet,
        "pm4py": pm["version"],
    }


def declare_violates(template: str, acts: tuple[str, str], trace: tuple[str, ...]) -> bool:
    """Declare's own reading of the two templates pm4py reads otherwise, computed directly: Not
    Succession(a, b) is violated where some b follows some a, Not Chain Succession(a, b) where
    a b directly follows an a."""
    a, b = acts
    if template == "nonsuccession":
        return a in trace and b in trace[trace.index(a) + 1 :]
    return any(x == a and y == b for x, y in itertools.pairwise(trace))


def report(r: dict) -> None:
    """One log's figures, as printed lines."""
    print(f"\n== {r['log']}: {r['cases']} cases, {r['constraints']} constraints discovered")
    print("   per template: " + ", ".join(f"{t} {n}" for t, n in sorted(r["per_template"].items())))
    print(
        f"   per-case violation counts agree on {r['agree']} of {r['cases']} cases "
        f"({r['agree'] / r['cases']:.2%}); without {', '.join(NOT_DECLARE)} "
        f"({r['declare_constraints']} constraints): {r['agree_declare']} of {r['cases']}"
    )
    print(
        f"   (case, constraint) pairs that differ: {r['differ_pairs']}"
        + (
            " — " + ", ".join(f"{t} {n}" for t, n in r["by_template"].most_common())
            if r["differ_pairs"]
            else ""
        )
    )
    print(
        f"   violated by pm4py only: {r['only_pm4py']}; by tleaf only: {r['only_tleaf']}; "
        f"templates without a constraint: "
        + (", ".join(sorted(set(PM4PY_TEMPLATES) - set(r["per_template"]))) or "none")
    )
    print(
        f"   tleaf against Declare's reading of {', '.join(NOT_DECLARE)} computed directly: "
        f"{r['direct_differ']} (case, constraint) pairs differ"
    )
    shown: Counter = Counter()
    for case, (template, acts), pm, tl in r["examples"]:
        if shown[template] >= EXAMPLES:
            continue
        shown[template] += 1
        print(
            f"   case {case.case_id}: {template}{acts}: pm4py "
            f"{'violated' if pm else 'satisfied'}, tleaf {'violated' if tl else 'satisfied'}; "
            f"activities {' > '.join(case.activities)}"
        )
    pm_s, tl_s = r["seconds"]
    print(
        f"   seconds: pm4py discovery + check {pm_s:.1f}, tleaf check {tl_s:.1f} "
        f"({r['alphabet']} letters)"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("logs", nargs="+", type=Path, help="event logs (.xes[.gz], .csv[.gz])")
    parser.add_argument(
        "--min-support",
        type=float,
        default=None,
        help="pm4py's min_support_ratio (default: pm4py's automatic choice)",
    )
    parser.add_argument(
        "--peers-python",
        type=Path,
        default=None,
        help="the peers' python (default: TLEAF_PEERS_PYTHON, else .venv-peers/bin/python)",
    )
    args = parser.parse_args(argv)
    python = peers_python(args.peers_python)
    disagreements = 0
    for path in args.logs:
        r = compare(path, args.min_support, python)
        report(r)
        disagreements += r["cases"] - r["agree"]
    return 0 if disagreements == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
