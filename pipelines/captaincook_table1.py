"""The CaptainCook4D page's section "Table I on real traces", from pipelines/captaincook.mk's runs.

    python pipelines/captaincook_table1.py T1 -o SECTION.md [--command C] [--page PAGE]

T1: the pipeline's table1/ folder: seed<s>/eval-<preset>-real/report.json (eval model-checking
on recording_traces.parquet: test = the held-out recipes' real recordings) and
seed<s>/eval-<preset>-synthetic/report.json (the same q on the same recipes' synthetic test
traces), recording_traces.parquet and recipes.ltl. Per preset, mean over the seeds found, of the
MLP chosen on val: on the real recordings, the accuracy against the exact answer (the report's
`all_accuracy`), the share of recordings that keep their rules recognised as keeping (its
`accuracy`, which reads satisfying and uniform traces only, so here the keeping recordings), the
share that break recognised as breaking (from the two), and their mean (balanced accuracy); on the
synthetic test traces, the accuracy; and the goal, the real accuracy within GOAL_POINTS of the
synthetic one (Table I's figure, on satisfying and uniform violating traces: the report's
`accuracy`). With PAGE, the section replaces the text between the page's markers for this folder
(or goes at its end if it has none).
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
from pathlib import Path

import pyarrow.parquet as pq

from tleaf_cli.data.artifacts import read_provenance

GOAL_POINTS = 5.0
REPORT = re.compile(r"seed(?P<seed>\d+)/eval-(?P<preset>[\w-]+)-(?P<data>real|synthetic)/")


def read_reports(t1: Path) -> dict[str, dict[str, dict[int, dict]]]:
    """preset -> "real" / "synthetic" -> seed -> the report's scores of the MLP (and, under
    "distance", of the distance rule)."""
    found: dict[str, dict[str, dict[int, dict]]] = {}
    for path in sorted(t1.glob("seed*/eval-*/report.json")):
        m = REPORT.search(path.relative_to(t1).as_posix() + "/")
        if m is None:
            continue
        report = json.loads(path.read_text())
        cell = found.setdefault(m["preset"], {}).setdefault(m["data"], {})
        cell[int(m["seed"])] = {**report["mlp"], "distance": report["distance"]}
    return found


def recorded_counts(t1: Path) -> tuple[int, int, list[str]]:
    """Test recordings that keep and that break their recipe's rules, and the held-out recipes."""
    table = pq.read_table(t1 / "recording_traces.parquet", columns=["formula_id", "label", "split"])
    rows = [r for r in table.to_pylist() if r["split"] == "test"]
    keeps = sum(1 for r in rows if r["label"])
    return keeps, len(rows) - keeps, sorted({r["formula_id"] for r in rows})


def real_scores(mlp: dict, keeps: int, breaks: int) -> dict[str, float]:
    """The real recordings' scores (%) from a report's `mlp` scores: `all_accuracy` over every
    recording, `accuracy` over the keeping ones (the only ones it reads: recorded traces that
    break are not `uniform`), the breaking ones' share from the two, and their mean."""
    n = keeps + breaks
    keep = mlp["accuracy"]
    brk = (mlp["all_accuracy"] * n - keep * keeps) / breaks if breaks else float("nan")
    return {
        "accuracy": 100 * mlp["all_accuracy"],
        "keep": 100 * keep,
        "break": 100 * brk,
        "balanced": 100 * (keep + brk) / 2,
    }


def _mean(values: list[float]) -> str:
    if len(values) == 1:
        return f"{values[0]:.1f}"
    se = statistics.stdev(values) / len(values) ** 0.5
    return f"{statistics.mean(values):.1f} ± {se:.1f}"


def markers(t1: Path) -> tuple[str, str]:
    """The page's markers around the section of the folder `t1` (one section per folder)."""
    return f"<!-- captaincook-{t1.name} -->", f"<!-- /captaincook-{t1.name} -->"


def section(t1: Path, command: str) -> str:
    keeps, breaks, recipes = recorded_counts(t1)
    found = read_reports(t1)
    once_each = read_provenance(t1 / "traces.parquet").params.get("once_each", False)
    drawn = (
        "synthetic traces of their DFAs that read each of the recipe's steps exactly once, with "
        "up to 3 steps it does not name (the shape of a recording; their violating traces a "
        "random order or two steps swapped)"
        if once_each
        else "synthetic traces of their DFAs as Table I draws them: satisfying and uniform "
        "violating words, paired by length"
    )
    title = " (traces that read each step once)" if once_each else ""
    start, end = markers(t1)
    lines = [
        start,
        f"## Table I on real traces{title}: model checking real recordings from embeddings",
        "",
        "A q trained on the recipes' rule sets (one formula per recipe, the conjunction of its "
        f"rules, compiled one-hot; {drawn}; the "
        "recipes split train / val / test) predicts from z_φ and z_w alone whether a recording "
        "keeps its recipe's rules. The MLP is fitted on the train recipes' synthetic traces and "
        "chosen on the val recipes'; it is scored on every recording of the "
        f"{len(recipes)} held-out recipes ({', '.join(recipes)}): {keeps + breaks} recordings, "
        f"{keeps} keep and {breaks} break their rules (always answering the larger class: "
        f"{100 * max(keeps, breaks) / (keeps + breaks):.1f} %), and on the same recipes' "
        "synthetic test traces (satisfying and uniform violating: Table I's figure). "
        "Accuracy against the exact answer (check-recordings), %, of Table I's MLP and, in the "
        "last column, of the distance rule d(z_φ, z_w) < τ (τ chosen on val; the form the logic "
        "loss relies on):",
        "",
        "| q preset | seeds | real: accuracy | real: keeping recognised | real: breaking "
        "recognised | real: balanced | synthetic: accuracy | real − synthetic | within "
        f"{GOAL_POINTS:g} points | distance rule: real / synthetic |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    missing = []
    real_means: dict[str, float] = {}  # preset -> its mean accuracy on the real recordings
    for preset in sorted(found):
        real, synthetic = found[preset].get("real", {}), found[preset].get("synthetic", {})
        seeds = sorted(set(real) & set(synthetic))
        missing += [f"{preset} seed {s}" for s in sorted(set(real) ^ set(synthetic))]
        if not seeds:
            continue
        scores = [real_scores(real[s], keeps, breaks) for s in seeds]
        synth = [100 * synthetic[s]["accuracy"] for s in seeds]
        real_means[preset] = statistics.mean(x["accuracy"] for x in scores)
        gap = real_means[preset] - statistics.mean(synth)
        cells = [_mean([x[k] for x in scores]) for k in ("accuracy", "keep", "break", "balanced")]
        met = "met" if abs(gap) <= GOAL_POINTS else "not met"
        lines.append(
            f"| {preset} | {len(seeds)} | {' | '.join(cells)} | {_mean(synth)} | {gap:+.1f} "
            f"| {met} | {_mean([100 * real[s]['distance']['all_accuracy'] for s in seeds])} / "
            f"{_mean([100 * synthetic[s]['distance']['accuracy'] for s in seeds])} |"
        )
    larger = 100 * max(keeps, breaks) / (keeps + breaks)
    above = [p for p, acc in real_means.items() if acc > larger]
    lines += [
        "",
        f"Above always answering the larger class ({larger:.1f} %) on the real recordings: "
        f"{', '.join(above) if above else 'no preset'}.",
    ]
    reports = list(t1.glob("seed*/eval-*/report.json"))
    wall = max(p.stat().st_mtime for p in reports) - (t1 / "recipes.ltl").stat().st_mtime
    lines += [
        "",
        f"Command: `{command}`; wall time {wall:.0f} s (from the recipe formulas to the last "
        f"evaluation, in {t1}).",
    ]
    if missing:
        lines.append(f"Not run on both kinds of traces: {', '.join(missing)}.")
    lines.append(end)
    return "\n".join(lines) + "\n"


def splice(page: str, text: str, start: str, end: str) -> str:
    """`page` with the text between its markers `start` and `end` replaced by `text` (markers
    included), or with `text` at its end when it has no markers."""
    if start in page and end in page:
        head, rest = page.split(start, 1)
        return head + text.rstrip("\n") + rest.split(end, 1)[1]
    return page.rstrip("\n") + "\n\n" + text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("t1", type=Path)
    parser.add_argument("-o", "--out", type=Path, required=True)
    parser.add_argument("--command", default="make -f pipelines/captaincook.mk")
    parser.add_argument("--page", type=Path)
    args = parser.parse_args()
    text = section(args.t1, args.command)
    args.out.write_text(text)
    if args.page is not None:
        page = args.page.read_text()
        args.page.write_text(splice(page, text, *markers(args.t1)))


if __name__ == "__main__":
    main()
