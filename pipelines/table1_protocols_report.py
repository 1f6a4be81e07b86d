"""The Table I section "both ways" from pipelines/table1_protocols.mk's runs.

    python pipelines/table1_protocols_report.py OUT -o SECTION.md [--page PAGE] [--settings S]

OUT: the pipeline's folder (<protocol>/<tier>/seed<s>/eval-<preset>/report.json, and the
per-call wall times the pipeline appends to OUT/times.tsv). Each cell is the MLP's test balanced
accuracy at the epoch chosen on val (`mlp`) and at its best test epoch (`mlp_best_test`,
recorded by eval model-checking, never used to choose), mean ± standard error over the seeds
found, beside the paper's figures. Cells not run are listed as missing. With PAGE, the section
replaces the text between the page's markers (or goes under its title if it has none). S: the
make variables of the run, printed in the section's command.

With --ablation VARIANTS, the ablation's table follows the grid's: OUT/ablation/<variant>/<tier>/
report.json (the MLP's val-chosen score) and q_m's val triplet accuracy (its metrics.json), one
row per variant, each one choice of `paper-code` on the authors' data changed toward `best`.
"""

from __future__ import annotations

import argparse
import csv
import json
import re
import statistics
from collections import defaultdict
from pathlib import Path

TIERS = ("low", "moderate", "high")
PAPER = {"low": (83.43, 0.73), "moderate": (78.43, 1.54), "high": (66.90, 0.70)}  # DFA row
PROTOCOL_NAMES = {"paper": "authors' (`--protocol paper`)", "tleaf": "tleaf's tiers"}
GOAL_POINTS = 2.0  # the reproduction is met when the val-chosen mean is this close to the paper
START, END = "<!-- table1-protocols -->", "<!-- /table1-protocols -->"
CELL = re.compile(
    r"(?P<protocol>[\w-]+)/(?P<tier>low|moderate|high)/seed(?P<seed>\d+)/"
    r"eval-(?P<preset>[\w-]+)/report\.json$"
)
# a call's output (-o PATH): a tier's data or q_e, or a cell's q_m (meta-) or evaluation (eval-)
CALL = re.compile(
    r"-o \S*/(?P<protocol>[\w-]+)/(?P<tier>low|moderate|high)/"
    r"(?:seed\d+/(?P<kind>meta|eval)-(?P<preset>[\w-]+)|(?P<data>\S+))"
)

# the ablation's variants: what each changes (pipelines/table1_protocols.mk, ABL_ lines, holds
# their options)
VARIANTS = {
    "base": "none (the `paper-code` / authors' cell above, seed 0)",
    "trimmed": "q: the dead state and the edges into it left out, as in the authors' spot "
    "automata (`--no-dead-state`; toward the authors, not tleaf)",
    "positives": "data: tleaf's sampler (K uniform accepted words of 2-12 letters, each with a "
    "uniform rejected word of its length)",
    "negatives": "data: half the negatives tleaf's hard ones (`--paper-hard 0.5`)",
    "formulas": "data: tleaf's tier formulas (the authors' traces; a formula their filters "
    "would drop has none)",
    "directed": "q: arcs both ways (`--no-directed`)",
    "readout": "q: expected walk of 24 steps from the initial state (`--readout walk`)",
    "sphere": "q: no unit scaling (`--no-sphere`)",
    "optimiser": "q: Adam 1e-3, no weight decay, cosine",
    "distance": "q: squared distance (`--distance squared`)",
}
ABLATION_START, ABLATION_END = "<!-- table1-ablation -->", "<!-- /table1-ablation -->"

Cells = dict[tuple[str, str, str], dict[int, dict]]  # (protocol, preset, tier) -> seed -> scores


def cells_of(out: Path) -> Cells:
    """Every evaluation under `out`: its val-chosen and best-test MLP scores and epochs."""
    cells: Cells = defaultdict(dict)
    for path in sorted(out.rglob("report.json")):
        match = CELL.search(path.relative_to(out).as_posix())
        if not match:
            continue
        report = json.loads(path.read_text())
        kept = [e for e in report.get("mlp_epochs", []) if e["kept"]]
        best = report.get("mlp_best_test")
        cells[match["protocol"], match["preset"], match["tier"]][int(match["seed"])] = {
            "val_chosen": 100 * report["mlp"]["balanced_accuracy"],
            "best_test": None if best is None else 100 * best["test_balanced_accuracy"],
            "kept_epoch": kept[-1]["epoch"] if kept else None,
            "best_epoch": None if best is None else best["epoch"],
            "epochs": len(report.get("mlp_epochs", [])),
            "pair_features": report["settings"]["pair_features"],
        }
    return cells


def wall_times(out: Path) -> dict[tuple[str, ...], float]:
    """Wall seconds summed per (protocol, tier, 'data') and (protocol, tier, kind, preset) from
    OUT/times.tsv (wall, user, system, command; absent: no times)."""
    times: dict[tuple[str, ...], float] = defaultdict(float)
    path = out / "times.tsv"
    if not path.exists():
        return times
    with path.open() as f:
        for row in csv.reader(f, delimiter="\t"):
            if len(row) < 4 or not re.match(r"^[\d.]+$", row[0]):
                continue  # /usr/bin/time's notes (a non-zero exit) take a line of their own
            match = CALL.search(row[3])
            if not match or ablation_call(row[3]):
                continue
            if match["data"]:
                times[match["protocol"], match["tier"], "data"] += float(row[0])
            else:
                key = (match["protocol"], match["tier"], match["kind"], match["preset"])
                times[key] += float(row[0])
            times["all",] += float(row[0])
    return times


def ablation_call(command: str) -> bool:
    """Whether a recorded call is the ablation's (its runs, or the data only it reads)."""
    return bool(re.search(r"-o \S*(/ablation/|/tiers-paper/|/traces-[\w-]+\.parquet)", command))


def ablation_seconds(out: Path) -> float:
    """Wall seconds of the ablation's calls in OUT/times.tsv."""
    path = out / "times.tsv"
    if not path.exists():
        return 0.0
    with path.open() as f:
        rows = [r for r in csv.reader(f, delimiter="\t") if len(r) >= 4]
    return sum(float(r[0]) for r in rows if re.match(r"^[\d.]+$", r[0]) and ablation_call(r[3]))


def ablation_section(out: Path, variants: list[str], tiers: list[str], settings: str = "") -> str:
    """The ablation's table: per variant and tier, the MLP's val-chosen test score and q_m's
    val triplet accuracy (`–` where not run)."""

    def cell(variant: str, tier: str) -> str:
        report = out / "ablation" / variant / tier / "report.json"
        if variant == "base":
            meta = out / "paper" / tier / "seed0" / "meta-paper-code" / "metrics.json"
        else:
            meta = out / "ablation" / variant / tier / "meta" / "metrics.json"
        if not report.exists():
            return "–"
        score = 100 * json.loads(report.read_text())["mlp"]["balanced_accuracy"]
        if not meta.exists():
            return f"{score:.2f}"
        triplets = json.loads(meta.read_text())["best"]["heldout_accuracy"]
        return f"{score:.2f} ({triplets:.2f})"

    names = [t.capitalize() for t in tiers]
    command = "make -f pipelines/table1_protocols.mk ablation " + (
        f"{settings} " if settings else ""
    )
    lines = [
        ABLATION_START,
        "### What each choice is worth: one change at a time from `paper-code` on the authors' "
        "data (SYNTHETIC, seed 0)",
        "Balanced accuracy (%) at the val-chosen MLP epoch (q_m's val triplet accuracy in "
        "brackets); a data variant is scored on its own test traces.",
        "",
        "| change | " + " | ".join(names) + " |",
        "|---|" + "---|" * len(tiers),
        *(
            f"| {VARIANTS.get(v, v)} | " + " | ".join(cell(v, t) for t in tiers) + " |"
            for v in variants
        ),
        "",
        f"Wall time {ablation_seconds(out):.0f} s (one call at a time, `OMP_NUM_THREADS=1`; the "
        f"base and the data it shares with the grid not counted): `{command}TLEAF=.venv/bin/tleaf`",
        ABLATION_END,
    ]
    return "\n".join(lines) + "\n"


def mean_se(values: list[float]) -> str:
    if not values:
        return "–"
    if len(values) == 1:
        return f"{values[0]:.2f} (1 seed)"
    se = statistics.stdev(values) / len(values) ** 0.5
    return f"{statistics.mean(values):.2f} ± {se:.2f} ({len(values)} seeds)"


def section(
    out: Path,
    settings: str = "",
    protocols: list[str] | None = None,
    presets: list[str] | None = None,
    seeds: list[int] | None = None,
) -> str:
    """The section; `protocols`, `presets`, `seeds`: the grid the run asked for (default: what
    is found), whose cells not found are listed as not run."""
    cells = cells_of(out)
    times = wall_times(out)
    found_protocols = {p for p, _, _ in cells} | set(protocols or [])
    protocols = sorted(found_protocols, key=lambda p: (p != "paper", p))
    presets = sorted(
        {e for _, e, _ in cells} | set(presets or []), key=lambda e: (e != "paper-code", e)
    )
    lines = [
        START,
        "## Table I both ways: the authors' data and q beside tleaf's (SYNTHETIC)",
        "",
        "Balanced accuracy (%) of the MLP 512-128 on test formulas never trained on, mean ± s.e. "
        "over the model seeds run, at the MLP epoch chosen on val and at the MLP's best test "
        "epoch (recorded by `eval model-checking`, never used to choose: what choosing on test, "
        "which the authors' script allows, would be worth).",
        "",
        "| q (`train-meta --preset`) | data | MLP epoch | Low | Moderate | High |",
        "|---|---|---|---|---|---|",
        "| paper: DFA (T-LEAF) | the authors' | not stated | "
        + " | ".join(f"{PAPER[t][0]:.2f} ± {PAPER[t][1]:.2f}" for t in TIERS)
        + " |",
    ]
    for preset in presets:
        for protocol in protocols:
            for which, name in (("val_chosen", "val-chosen"), ("best_test", "best test")):
                row = [
                    mean_se(
                        [
                            c[which]
                            for c in cells.get((protocol, preset, t), {}).values()
                            if c[which] is not None
                        ]
                    )
                    for t in TIERS
                ]
                lines.append(
                    f"| `{preset}` | {PROTOCOL_NAMES.get(protocol, protocol)} | {name} | "
                    + " | ".join(row)
                    + " |"
                )
    lines += [
        "",
        *goal_lines(cells),
        *epoch_lines(cells),
        *missing_lines(cells, protocols, presets),
    ]
    lines += ["", *cost_lines(times, protocols, presets)]
    # TLEAF last: the docs' tests read the words after a tleaf path as a tleaf call
    command = "make -f pipelines/table1_protocols.mk " + (f"{settings} " if settings else "")
    command += "TLEAF=.venv/bin/tleaf"
    lines += ["", "```bash", command, "```", END]
    return "\n".join(lines) + "\n"


def goal_lines(cells: Cells) -> list[str]:
    """Whether the authors' q on the authors' data is within GOAL_POINTS of the paper."""
    parts = []
    for t in TIERS:
        runs = cells.get(("paper", "paper-code", t), {})
        if not runs:
            parts.append(f"{t} not run")
            continue
        gap = statistics.mean(c["val_chosen"] for c in runs.values()) - PAPER[t][0]
        verdict = "within" if abs(gap) <= GOAL_POINTS else "not within"
        parts.append(f"{t} {gap:+.2f} ({verdict} {GOAL_POINTS:g}, {len(runs)} seeds)")
    return [
        "`paper-code` on the authors' data against the paper, val-chosen epoch: "
        + "; ".join(parts)
        + "."
    ]


def epoch_lines(cells: Cells) -> list[str]:
    """Each preset's MLP input, and per cell (seed 0 or the first seed run) the MLP epoch kept
    on val, the best test epoch and the epochs trained (early stop: 10 without a better val)."""
    parts, features = [], {}
    for (protocol, preset, tier), runs in sorted(cells.items()):
        c = runs[min(runs)]
        features[preset] = c["pair_features"]
        parts.append(
            f"{preset} / {protocol} / {tier}: {c['kept_epoch']} / {c['best_epoch']} / {c['epochs']}"
        )
    return [
        "MLP input: " + ", ".join(f"`{e}` {f}" for e, f in sorted(features.items())) + ". "
        "MLP epoch kept on val / best test epoch / epochs trained (first seed): "
        + "; ".join(parts)
        + "."
    ]


def missing_lines(
    cells: Cells, protocols: list[str], presets: list[str], seeds: list[int] | None = None
) -> list[str]:
    seeds = sorted({s for runs in cells.values() for s in runs} | set(seeds or []))
    missing = [
        f"{preset} / {protocol} / {t} seed {s}"
        for preset in presets
        for protocol in protocols
        for t in TIERS
        for s in seeds
        if s not in cells.get((protocol, preset, t), {})
    ]
    return [f"Not run: {', '.join(missing)}." if missing else "Every cell has every seed."]


def cost_lines(times: dict, protocols: list[str], presets: list[str]) -> list[str]:
    """Wall seconds per protocol and tier: data and q_e, then each preset's train-meta + eval
    (summed over the seeds run)."""
    if not times:
        return ["No wall times recorded (OUT/times.tsv absent)."]

    def cell(p: str, t: str) -> str:
        parts = [f"data and q_e {times[p, t, 'data']:.0f}"] if (p, t, "data") in times else []
        for e in presets:
            meta, ev = times.get((p, t, "meta", e)), times.get((p, t, "eval", e))
            if meta is not None or ev is not None:
                parts.append(f"{e} {meta or 0:.0f} + {ev or 0:.0f}")
        return " · ".join(parts) or "–"

    return [
        f"Wall seconds, summed over calls ({times['all',]:.0f} s in all, one call at a time, "
        "`OMP_NUM_THREADS=1`): data and q_e, then each q's train-meta + eval:",
        "",
        "| data | Low | Moderate | High |",
        "|---|---|---|---|",
        *(
            f"| {PROTOCOL_NAMES.get(p, p).split(' (')[0]} | "
            + " | ".join(cell(p, t) for t in TIERS)
            + " |"
            for p in protocols
        ),
    ]


def write_page(page: Path, text: str, start: str = START, end: str = END) -> None:
    """The section between the page's markers; if none, the ablation's under the grid's
    section, the grid's under the page's title (first line)."""
    old = page.read_text()
    if start not in old and start == ABLATION_START and END in old:
        old = old.replace(END, f"{END}\n\n{start}\n{end}", 1)
    if start in old and end in old:
        before, rest = old.split(start, 1)
        after = rest.split(end, 1)[1]
        new = before + text.rstrip("\n") + after
    else:
        title, _, body = old.partition("\n")
        new = f"{title}\n\n{text}\n{body.lstrip(chr(10))}"
    page.write_text(new)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("-o", "--output", type=Path, required=True)
    parser.add_argument("--page", type=Path)
    parser.add_argument("--settings", default="")
    parser.add_argument("--protocols", default="", help="the grid asked for (space-separated)")
    parser.add_argument("--presets", default="")
    parser.add_argument("--seeds", default="")
    parser.add_argument("--ablation", default="", help="the ablation's variants (space-separated)")
    parser.add_argument("--ablation-tiers", default="low moderate high")
    parser.add_argument("--ablation-settings", default="")
    args = parser.parse_args()
    text = section(
        args.out,
        args.settings,
        args.protocols.split(),
        args.presets.split(),
        [int(x) for x in args.seeds.split()],
    )
    if args.page:
        write_page(args.page, text)
    if args.ablation:
        ablation = ablation_section(
            args.out, args.ablation.split(), args.ablation_tiers.split(), args.ablation_settings
        )
        text += "\n" + ablation
        if args.page:
            write_page(args.page, ablation, ABLATION_START, ABLATION_END)
    args.output.write_text(text)


if __name__ == "__main__":
    main()
