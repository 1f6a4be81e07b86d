"""The learning curve on real event logs (pipelines/learning_curve_logs.mk): its tables.

Reads OUT/<log>/p<share>/s<seed>/ (exact/metrics.json: the λ chosen on val, the training cases;
eval-none/ and eval-exact/metrics.json: test accuracy by argmax and under the mined rules) and
writes a page (curve.md) and every figure (curve.json beside it):

- per log and share: the four variants' test accuracy, mean ± sd over the seeds — none (the
  λ-0 reference, argmax), none under the rules, exact (λ on val), exact under the rules;
- the best knowledge variant at each share (the highest mean of the three that use the rules;
  chosen on test, so an optimistic pick, and said so), its Δ against the reference of the same
  seed and how many seeds it beats it in, and its **data worth**: the share the reference's
  curve of mean accuracies needs to reach the variant's mean (linear between shares on a log
  scale, its first crossing; `reference_videos` of tleaf's synthetic curve), over the
  variant's own share. Beyond the largest share it is a lower bound ("> x×"), at or below the
  reference's first point an upper bound ("≤ x×"). Beside it the worth of a gain one standard
  error lower (Δ against the same seed's reference, minus its s.e.): what the spread leaves;
- every variant's data worth, and the λ chosen per seed;
- the goal: knowledge worth ≥ 2× the data at ≤ 10 % of the cases on at least 2 of the logs.

    python pipelines/learning_curve_logs_report.py OUT [-o OUT/curve.md] [--logs "A B C"]
        [--command "make ..."]
"""

from __future__ import annotations

import argparse
import json
import math
import re
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path

from tleaf_cli.tasks.action_recognition.learning_curve import Worth, reference_videos

VARIANTS = {  # name -> (evaluation folder, accuracy key)
    "none": ("eval-none", "accuracy"),
    "none, rules": ("eval-none", "accuracy_rules"),
    "exact": ("eval-exact", "accuracy"),
    "exact, rules": ("eval-exact", "accuracy_rules"),
}
REFERENCE = "none"
KNOWLEDGE = ("none, rules", "exact", "exact, rules")
GOAL_WORTH = 2.0  # the knowledge worth at least twice the data ...
GOAL_SHARE = 10.0  # ... at 10 % of the training cases or fewer ...
GOAL_LOGS = 2  # ... on this many logs
UNIT = re.compile(r"p(?P<share>[0-9.]+)/s(?P<seed>[0-9]+)$")


def read_units(out: Path, log: str) -> list[dict]:
    """Every finished unit of `log` under `out`: share (%), seed, training cases, λ chosen, each
    variant's test accuracy; units without both evaluations are left out."""
    rows = []
    for unit in sorted((out / log).glob("p*/s*")):
        match = UNIT.search(unit.as_posix())
        if not match:
            continue
        files = [unit / "exact" / "metrics.json"] + [
            unit / f / "metrics.json" for f, _ in VARIANTS.values()
        ]
        if not all(f.is_file() for f in files):
            continue
        train = json.loads(files[0].read_text())
        evals = {
            f: json.loads((unit / f / "metrics.json").read_text()) for f, _ in VARIANTS.values()
        }
        row = {
            "share": float(match["share"]),
            "seed": int(match["seed"]),
            "train_cases": int(train["cases"]["train"]),
            "lambda": float(train["lambda"]["value"]),
            "epochs": int(train["best"]["epoch"]),
        }
        for name, (folder, key) in VARIANTS.items():
            row[name] = 100.0 * float(evals[folder]["accuracy"][key])
        row["changed_by_rules"] = {
            "none": int(evals["eval-none"]["accuracy"].get("changed_by_rules", 0)),
            "exact": int(evals["eval-exact"]["accuracy"].get("changed_by_rules", 0)),
        }
        row["seconds"] = training_seconds(unit / "times.tsv")
        config = unit / "exact" / "config.json"
        settings = json.loads(config.read_text()).get("settings", {}) if config.is_file() else {}
        row["schedule"] = (settings.get("epochs"), settings.get("patience"))
        rows.append(row)
    return rows


def training_seconds(path: Path) -> float | None:
    """The wall seconds of the unit's training (pipelines/timed-tleaf's first column)."""
    if not path.is_file():
        return None
    lines = [line.split("\t") for line in path.read_text().splitlines() if line.strip()]
    return sum(float(f[0]) for f in lines) if lines else None


def mean_sd(values: Sequence[float]) -> tuple[float, float]:
    """Mean and sample standard deviation (0 for one value)."""
    mean = statistics.fmean(values)
    return mean, statistics.stdev(values) if len(values) > 1 else 0.0


def data_worth(
    shares: Sequence[float], reference: Sequence[float], target: float, share: float
) -> Worth:
    """What a variant at `share` % with mean accuracy `target` is worth in data: the share the
    reference's curve (mean accuracy per share, shares increasing) first reaches `target` at,
    linear between shares on log(share), over `share`; a bound where the curve does not cross."""
    at = reference_videos(list(shares), list(reference), target)
    return Worth(at.videos / share, at.bound, at.videos)


def curve(rows: list[dict]) -> dict:
    """One log's curve: per share, each variant's mean ± sd, the best knowledge variant, its Δ
    against the same seed's reference, the seeds it beats it in, and every variant's data
    worth against the reference's curve."""
    shares = sorted({r["share"] for r in rows})
    points = []
    for share in shares:
        at = sorted((r for r in rows if r["share"] == share), key=lambda r: r["seed"])
        point = {
            "share": share,
            "seeds": [r["seed"] for r in at],
            "train_cases": sorted({r["train_cases"] for r in at}),
            "lambdas": [r["lambda"] for r in at],
            "seconds": [r["seconds"] for r in at],
            "schedules": sorted({r.get("schedule", (None, None)) for r in at}, key=str),
            "variants": {},
        }
        for name in VARIANTS:
            values = [r[name] for r in at]
            mean, sd = mean_sd(values)
            deltas = [r[name] - r[REFERENCE] for r in at]
            point["variants"][name] = {
                "values": values,
                "mean": mean,
                "sd": sd,
                "delta_mean": statistics.fmean(deltas),
                "delta_sd": mean_sd(deltas)[1],
                "above": sum(d > 0 for d in deltas),
                "equal": sum(d == 0 for d in deltas),
            }
        points.append(point)
    reference = [p["variants"][REFERENCE]["mean"] for p in points]
    for point in points:
        for name in KNOWLEDGE:
            v = point["variants"][name]
            worth = data_worth(shares, reference, v["mean"], point["share"])
            v["worth"] = {"ratio": worth.ratio, "bound": worth.bound, "share": worth.videos}
            # the same with the gain one standard error lower (paired by seed): how much of
            # the worth the seeds' spread leaves
            se = v["delta_sd"] / math.sqrt(len(point["seeds"]))
            ref_here = point["variants"][REFERENCE]["mean"]
            low = data_worth(shares, reference, ref_here + v["delta_mean"] - se, point["share"])
            v["worth_low"] = {"ratio": low.ratio, "bound": low.bound, "share": low.videos}
        best = max(KNOWLEDGE, key=lambda n: point["variants"][n]["mean"])
        point["best"] = best
    return {"shares": shares, "points": points}


def worth_text(w: dict) -> str:
    return Worth(w["ratio"], w["bound"], w["share"]).text()


def goal(curves: dict[str, dict]) -> dict:
    """The done-when: per log, the most the best knowledge variant is worth at ≤ 10 %."""
    per_log = {}
    for log, c in curves.items():
        small = [p for p in c["points"] if p["share"] <= GOAL_SHARE]
        if not small:
            per_log[log] = None
            continue
        top = max(small, key=lambda p: p["variants"][p["best"]]["worth"]["ratio"])
        w = top["variants"][top["best"]]["worth"]
        # a ratio counts where it is measured ("=") or a lower bound (">"); an upper bound does
        # not show the goal met
        met = w["ratio"] >= GOAL_WORTH and w["bound"] in ("=", ">")
        per_log[log] = {"share": top["share"], "variant": top["best"], "worth": w, "met": met}
    logs_met = sum(bool(v and v["met"]) for v in per_log.values())
    return {"per_log": per_log, "logs_met": logs_met, "met": logs_met >= GOAL_LOGS}


def fmt(share: float) -> str:
    return f"{share:g}"


def render(curves: dict[str, dict], result: dict, command: str | None) -> str:
    lines = [
        "# Learning curve on real event logs",
        "",
        "Next-activity test accuracy (%, pooled over every prefix of the test cases, the end a "
        "target), mean ± sd over seeds; the share of the fold's training cases kept, drawn by the "
        "seed; rules mined from the kept cases. Best: the knowledge variant with the highest mean "
        "(picked on test: optimistic). Δ: against the reference of the same seed, in points; "
        "above: seeds where it beats the reference. Worth: the share the reference needs for the "
        "best variant's mean (linear on log share), over its own share; at Δ − s.e.: the same "
        "for a gain one standard error lower.",
        "",
    ]
    if command:
        lines += [f"Command: `{command}`", ""]
    for log, c in curves.items():
        lines += [
            f"## {log}",
            "",
            "| share | train cases | seeds | "
            + " | ".join(VARIANTS)
            + " | best | Δ best | above | worth | worth at Δ − s.e. |",
            "|---" * 12 + "|",
        ]
        for p in c["points"]:
            v = p["variants"]
            best = v[p["best"]]
            cells = [f"{v[n]['mean']:.2f} ± {v[n]['sd']:.2f}" for n in VARIANTS]
            low, high = p["train_cases"][0], p["train_cases"][-1]
            cases = str(low) if low == high else f"{low}–{high}"
            lines.append(
                f"| {fmt(p['share'])} % | {cases} | {len(p['seeds'])} | "
                + " | ".join(cells)
                + f" | {p['best']} | {best['delta_mean']:+.2f} ± {best['delta_sd']:.2f} | "
                f"{best['above']}/{len(p['seeds'])} | {worth_text(best['worth'])} | "
                f"{worth_text(best['worth_low'])} |"
            )
        lines += [
            "",
            "| share | "
            + " | ".join(f"worth: {n}" for n in KNOWLEDGE)
            + " | λ chosen per seed | epochs / patience | training wall (s, mean per seed) |",
            "|---" * 7 + "|",
        ]
        for p in c["points"]:
            secs = [s for s in p["seconds"] if s is not None]
            wall = f"{statistics.fmean(secs):.0f}" if secs else "–"
            lams = ", ".join(f"{x:g}" for x in p["lambdas"])
            plan = ", ".join(f"{e} / {q}" if e else "–" for e, q in p["schedules"])
            lines.append(
                f"| {fmt(p['share'])} % | "
                + " | ".join(worth_text(p["variants"][n]["worth"]) for n in KNOWLEDGE)
                + f" | {lams} | {plan} | {wall} |"
            )
        lines.append("")
    lines += ["## Goal", ""]
    for log, g in result["per_log"].items():
        if g is None:
            lines.append(f"- {log}: no share at or below {GOAL_SHARE:g} % measured")
            continue
        lines.append(
            f"- {log}: at most {worth_text(g['worth'])} at ≤ {GOAL_SHARE:g} % "
            f"({g['variant']}, {fmt(g['share'])} %): {'met' if g['met'] else 'not met'}"
        )
    verdict = "met" if result["met"] else "not met"
    lines += [
        "",
        f"Knowledge worth ≥ {GOAL_WORTH:g}× the data at ≤ {GOAL_SHARE:g} % of the cases on at "
        f"least {GOAL_LOGS} of {len(curves)} logs: **{verdict}** ({result['logs_met']} of "
        f"{len(curves)}).",
        "",
    ]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="The pipeline's OUT folder.")
    parser.add_argument("-o", "--page", type=Path, help="The page to write (default OUT/curve.md).")
    parser.add_argument("--logs", help="The logs, in order (default: every folder of OUT).")
    parser.add_argument("--command", help="The command that ran, for the page.")
    args = parser.parse_args(argv)
    logs = (
        args.logs.split() if args.logs else sorted(p.name for p in args.out.iterdir() if p.is_dir())
    )
    curves = {}
    for log in logs:
        rows = read_units(args.out, log)
        if rows:
            curves[log] = curve(rows)
    if not curves:
        print(f"{args.out}: no finished unit of {', '.join(logs)}", file=sys.stderr)
        return 2
    result = goal(curves)
    page = args.page or args.out / "curve.md"
    page.parent.mkdir(parents=True, exist_ok=True)
    page.write_text(render(curves, result, args.command), encoding="utf-8")
    record = {"curves": curves, "goal": result, "command": args.command}
    page.with_suffix(".json").write_text(
        json.dumps(
            record,
            indent=1,
            default=lambda x: None if isinstance(x, float) and math.isnan(x) else x,
        ),
        encoding="utf-8",
    )
    verdict = "met" if result["met"] else "not met"
    print(f"{page}: {len(curves)} logs; goal {verdict} ({result['logs_met']} of {len(curves)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
