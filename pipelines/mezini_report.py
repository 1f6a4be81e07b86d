"""Mezini et al.'s protocol on their logs (BPI 2013 closed, ...): the joined logs and the report.

Two commands (pipelines/mezini.mk runs both):

    python pipelines/mezini_report.py join TRAIN.xes.gz TEST.xes.gz -o joined.xes --val 0.2
        One XES holding TRAIN's traces, then TEST's, and beside it joined.split: the
        `read-log --split` fractions (with --split-order file) that make the last --val share of
        TRAIN's cases validation and every TEST case test, exactly. train-task next-activity
        reads one cases artifact with all three splits, and eval scores the test split of the
        cases the run trained on, so the noisy training log and the clean test log are read as
        one file.

    python pipelines/mezini_report.py report OUT [--published CSV [--dataset NAME]] -o SECTION.md
        The markdown section: the run's record (OUT/record.json, pipelines/mezini_data.py: the
        prefix lengths, the longest suffix and the constraints left out of the model, each with
        why); per noise level and prefix length (whichever ran), the mean ± sd over the seeds
        of Mezini et al.'s trace similarity (eval's trace_dl_similarity) and the share of
        predicted cases satisfying the Declare model, for tleaf's reference (λ 0) and knowledge
        variants, greedy and sampled, with and without the rules as a hard filter, beside
        their baseline / LLL / GLL means from their per-run CSV (its rows of --dataset where it
        holds several logs; "–" where it has no figure for a noise level or prefix length); the
        per-seed win counts; the λ chosen on validation and every λ of the grid.

OUT's layout (pipelines/mezini.mk): OUT/n<noise>/s<seed>/<loss>/metrics.json (a train-task
run with --lambdas: its lambda-choice/lambda-<λ> candidates) and
OUT/n<noise>/s<seed>/eval-<loss>-<λ>/metrics.json (eval next-activity of one candidate).
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
from collections.abc import Iterable, Sequence
from pathlib import Path

# ---------------------------------------------------------------------------- join


def read_xes_text(path: Path) -> str:
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", encoding="utf-8") as f:
        return f.read()


def traces_of(text: str, path: Path) -> tuple[str, str, int]:
    """The text before the first <trace>, the traces' text (up to </log>), the trace count."""
    start, end = text.find("<trace>"), text.rfind("</log>")
    if start < 0 or end < start:
        raise SystemExit(f"{path}: no <trace> ... </log> in it: not an XES log")
    return text[:start], text[start:end], text.count("<trace>")


def split_fractions(n_train: int, n_val: int, n_test: int) -> str:
    """read-log's --split for the file order train, val, test: fractions whose rounded
    boundaries (read-log rounds each cumulative boundary to the nearest case) fall exactly at
    n_train and n_train + n_val."""
    total = n_train + n_val + n_test
    fractions = [n_train / total, n_val / total, n_test / total]
    text = ",".join(f"{f:.9f}" for f in fractions)
    bounds, cumulative = [], 0.0
    for f in (float(x) for x in text.split(",")):
        cumulative += f
        bounds.append(round(cumulative * total))
    if bounds != [n_train, n_train + n_val, total]:
        raise SystemExit(f"split {text} of {total} cases rounds to {bounds}")
    return text


def join(train: Path, test: Path, out: Path, val: float) -> tuple[int, int, int]:
    """Write TRAIN's traces then TEST's as one XES (TRAIN's header) and out.split; return the
    train / val / test case counts."""
    head, train_traces, n = traces_of(read_xes_text(train), train)
    _, test_traces, m = traces_of(read_xes_text(test), test)
    if n < 2 or m < 1:
        raise SystemExit(f"{train}: {n} traces, {test}: {m}: too few to split")
    n_val = max(1, round(val * n))
    out.write_text(head + train_traces.rstrip() + "\n\t" + test_traces.rstrip() + "\n</log>\n")
    out.with_suffix(".split").write_text(split_fractions(n - n_val, n_val, m) + "\n")
    return n - n_val, n_val, m


# ---------------------------------------------------------------------------- report

GREEDY = ("argmax", "argmax_rules")  # eval's ways: plain, and the rules as a hard filter
SAMPLED = ("sample", "sample_rules")
THEIRS = ("baseline", "LLL", "GLL")
STRATEGY = {"argmax": "greedy", "sample": "temperature"}
ALPHA = 0.65  # their α the comparison reads (the only one in the shipped extract)


def load_json(path: Path) -> dict:
    with open(path) as f:
        return json.load(f)


def lam_name(value: float) -> str:
    """A λ as train-task names its candidate folder (lambda-<%g>)."""
    return f"{value:g}"


def collect(out: Path) -> dict:
    """Every evaluation under OUT: {noise: {seed: unit}}, a unit {"evals": {(loss, λ): eval
    metrics.json}, "chosen": {loss: λ chosen on val}, "val": {loss: {λ: val accuracy}}}."""
    found: dict = {}
    for noise_dir in sorted(out.glob("n*")):
        m = re.fullmatch(r"n(\d+)", noise_dir.name)
        if not m or not noise_dir.is_dir():
            continue
        for seed_dir in sorted(noise_dir.glob("s*")):
            s = re.fullmatch(r"s(\d+)", seed_dir.name)
            if not s:
                continue
            unit: dict = {"evals": {}, "chosen": {}, "val": {}}
            for run in sorted(seed_dir.glob("*/metrics.json")):
                name = run.parent.name
                e = re.fullmatch(r"eval-([a-z]+)-(.+)", name)
                if e:
                    unit["evals"][(e.group(1), e.group(2))] = load_json(run)
                    continue
                choice = load_json(run).get("lambda") or {}
                if "value" in choice:
                    unit["chosen"][name] = lam_name(choice["value"])
                unit["val"][name] = {
                    lam_name(c["lambda"]): c["val_accuracy"] for c in choice.get("candidates", [])
                }
            if unit["evals"]:
                found.setdefault(int(m.group(1)), {})[int(s.group(1))] = unit
    return found


def prefixes_in(runs_by_noise: dict) -> list[str]:
    """The prefix lengths the evaluations scored suffixes at, shortest first."""
    found = {
        p
        for runs in runs_by_noise.values()
        for unit in runs.values()
        for ev in unit["evals"].values()
        for p in ev.get("suffix", {})
    }
    return sorted(found, key=int)


def short_prefixes(runs_by_noise: dict, prefixes: Sequence[str]) -> list[str]:
    """The prefix lengths some test case is shorter than (eval scores fewer cases there than
    it scores in all): where their count and eval's differ."""
    out = []
    for p in prefixes:
        for runs in runs_by_noise.values():
            for unit in runs.values():
                for ev in unit["evals"].values():
                    cases = ev.get("suffix", {}).get(p, {}).get("cases")
                    total = ev.get("scored_cases")
                    if cases is not None and total and cases < total and p not in out:
                        out.append(p)
    return out


def variant_eval(unit: dict, variant: str) -> dict | None:
    """A variant's evaluation in one unit: 'none' (λ 0, the reference), '<loss>' (its λ chosen
    on val), '<loss>@<λ>' (a fixed λ of its grid). λ 0 is the same run for every loss."""
    loss, _, lam = variant.partition("@")
    if variant == "none":
        lam = "0"
    elif not lam:
        lam = unit["chosen"].get(loss)
    if lam is None:
        return None
    if lam == "0":
        return next((ev for (_, x), ev in sorted(unit["evals"].items()) if x == "0"), None)
    return unit["evals"].get((loss, lam))


def figure(ev: dict | None, prefix: str, way: str, key: str, their_count: bool = False):
    """One figure of an evaluation (None where missing). their_count: the trace similarity as
    Mezini et al.'s code counts it at this prefix length, over every test case: a case with
    fewer events than the prefix scores 1 there (its prefix already holds the whole trace and
    its end), where eval scores only the cases at least that long."""
    if ev is None:
        return None
    scores = ev.get("suffix", {}).get(prefix, {})
    got = scores.get(way)
    if not isinstance(got, dict) or key not in got:
        return None
    value = float(got[key])
    if their_count:
        total, scored = ev.get("scored_cases"), scores.get("cases")
        if not total or not scored:
            return None
        value = (scored * value + (total - scored)) / total
    return value


def values(runs: dict, variant: str, prefix: str, way: str, key="trace_dl_similarity", **kw):
    """One figure per seed, in seed order (seeds without it left out)."""
    out = []
    for seed in sorted(runs):
        v = figure(variant_eval(runs[seed], variant), prefix, way, key, **kw)
        if v is not None:
            out.append(v)
    return out


def mean_sd(xs: Sequence[float]) -> tuple[float, float] | None:
    if not xs:
        return None
    return statistics.fmean(xs), statistics.stdev(xs) if len(xs) > 1 else 0.0


def cell(dl: Sequence[float], sat: Sequence[float] = ()) -> str:
    m = mean_sd(dl)
    if m is None:
        return "–"
    s = mean_sd(sat)
    return f"{m[0]:.3f} ± {m[1]:.3f}" + (f" / {s[0]:.2f}" if s is not None else "")


def wins(runs: dict, variant: str, way: str, prefix: str) -> tuple[int, int]:
    """Seeds where `variant` decoded `way` beats the same seed's reference (λ 0, plain argmax)
    on trace similarity, strictly; and the seeds compared."""
    won = total = 0
    for seed in sorted(runs):
        ours = figure(variant_eval(runs[seed], variant), prefix, way, "trace_dl_similarity")
        base = figure(variant_eval(runs[seed], "none"), prefix, "argmax", "trace_dl_similarity")
        if ours is None or base is None:
            continue
        total += 1
        won += ours > base
    return won, total


# ---- their per-run CSV


def read_published(path: Path, dataset: str | None = None) -> list[dict]:
    """Their rows (the columns of results/paper_results.csv the report reads): those of
    `dataset` (their `dataset` column), which must be given where the file holds several."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    need = {
        "noise",
        "alpha",
        "run_id",
        "loss",
        "prefix_length",
        "sampling_strategy",
        "test_similarity_scaled",
        "test_satisfiability",
    }
    if not rows or not need <= set(rows[0]):
        raise SystemExit(f"{path}: no rows, or missing columns {sorted(need - set(rows[0] or {}))}")
    logs = sorted({r.get("dataset", "") for r in rows})
    if dataset is not None:
        rows = [r for r in rows if r.get("dataset") == dataset]
        if not rows:
            raise SystemExit(f"{path}: no rows of dataset {dataset!r} (it has {', '.join(logs)})")
    elif len(logs) > 1:
        raise SystemExit(
            f"{path}: rows of {len(logs)} logs ({', '.join(logs)}): say which (--dataset, "
            "DATASET= in pipelines/mezini.mk)"
        )
    return rows


def published_means(rows: Iterable[dict]) -> dict:
    """{(noise, alpha, loss, prefix, strategy): (mean similarity, mean satisfiability, runs)}."""
    groups: dict = {}
    for r in rows:
        key = (
            int(r["noise"]),
            float(r["alpha"]),
            r["loss"],
            str(int(r["prefix_length"])),
            r["sampling_strategy"],
        )
        groups.setdefault(key, []).append(
            (float(r["test_similarity_scaled"]), float(r["test_satisfiability"]))
        )
    return {
        k: (statistics.fmean(a for a, _ in v), statistics.fmean(b for _, b in v), len(v))
        for k, v in groups.items()
    }


def theirs_cell(means: dict, noise: int, loss: str, prefix: str, strategy: str) -> str:
    got = means.get((noise, ALPHA, loss, prefix, strategy))
    return "–" if got is None else f"{got[0]:.3f} / {got[1]:.2f}"


# ---- the section


def losses_in(runs_by_noise: dict) -> list[str]:
    seen = {lo for runs in runs_by_noise.values() for u in runs.values() for lo in u["chosen"]}
    return [lo for lo in ("exact", "tleaf") if lo in seen] + sorted(seen - {"exact", "tleaf"})


def grid_of(runs_by_noise: dict, loss: str) -> list[str]:
    """The λ values evaluated for `loss`, and 0 (the reference), in order."""
    lams = {"0"}
    for runs in runs_by_noise.values():
        for unit in runs.values():
            lams.update(lam for lo, lam in unit["evals"] if lo == loss)
    return sorted(lams, key=float)


def knowledge_variants(losses: Sequence[str], ways: Sequence[str]) -> list[tuple[str, str, str]]:
    """(label, variant, way) of every knowledge variant: the rules at decoding on the reference,
    each loss (λ on val) alone and with the rules."""
    out = [("λ 0 + rules", "none", ways[1])]
    for lo in losses:
        out += [(lo, lo, ways[0]), (f"{lo} + rules", lo, ways[1])]
    return out


def table(runs_by_noise, variants, means, strategy, noises, prefixes, their_count=False):
    """Rows noise × prefix; columns tleaf's variants (label, variant, way), then theirs."""
    head = ["noise", "prefix", *[v[0] for v in variants]]
    head += [f"their {lo}" for lo in THEIRS] if means else []
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for noise in noises:
        runs = runs_by_noise.get(noise, {})
        for prefix in prefixes:
            row = [f"{noise} %", prefix]
            for _, variant, way in variants:
                dl = values(runs, variant, prefix, way, their_count=their_count)
                sat = [] if their_count else values(runs, variant, prefix, way, "satisfying")
                row.append(cell(dl, sat))
            if means:
                for lo in THEIRS:
                    theirs = theirs_cell(means, noise, lo, prefix, strategy)
                    row.append(theirs.split(" / ")[0] if their_count else theirs)
            lines.append("| " + " | ".join(row) + " |")
    return lines


def verdicts(
    runs_by_noise: dict, means: dict, losses: Sequence[str], prefixes: Sequence[str]
) -> list[str]:
    """The protocol's goals, per knowledge variant (greedy): wins over the reference in >= 4 of
    5 seeds at the two shortest prefixes (BPI 2013 closed: 1 and 2) at 30 and 40 % noise;
    greedy compliance 100 % (sampling >= 95 % for the same model sampled the same way); mean
    similarity at or above their LLL's (α 0.65) at every noise level and prefix that ran (on
    their count)."""
    short = list(prefixes[:2])
    lines = [
        "| variant (greedy) | wins ≥ 4 of 5 at 30 and 40 %, prefixes "
        f"{' and '.join(short)} | greedy compliance 100 % at 30 and 40 % | sampled "
        "compliance ≥ 95 % | ≥ their LLL, every noise level and prefix |",
        "|---|---|---|---|---|",
    ]
    for label, variant, way in knowledge_variants(losses, GREEDY):
        sampled_way = "sample_rules" if way.endswith("_rules") else "sample"
        win_cells, comply, sample_ok, above = [], True, True, []
        for noise in (30, 40):
            runs = runs_by_noise.get(noise, {})
            for prefix in short:
                w, n = wins(runs, variant, way, prefix)
                win_cells.append((noise, prefix, w, n))
            for prefix in prefixes:
                sat = values(runs, variant, prefix, way, "satisfying")
                comply &= bool(sat) and min(sat) >= 1.0
                sat_s = values(runs, variant, prefix, sampled_way, "satisfying")
                sample_ok &= bool(sat_s) and statistics.fmean(sat_s) >= 0.95
        theirs_at = {(k[0], k[3]) for k in means if k[1:3] == (ALPHA, "LLL") and k[4] == "greedy"}
        for noise in sorted(runs_by_noise):
            for prefix in (p for p in prefixes if (noise, p) in theirs_at):
                ours = mean_sd(values(runs_by_noise[noise], variant, prefix, way, their_count=True))
                theirs = means.get((noise, ALPHA, "LLL", prefix, "greedy"))
                if ours is not None and theirs is not None:
                    above.append((noise, prefix, ours[0] >= theirs[0] - 1e-9))
        won = all(n >= 5 and w >= 4 for _, _, w, n in win_cells)
        failed = [f"{n} % p{p}: {w}/{t}" for n, p, w, t in win_cells if w < 4]
        below = [f"{n} % p{p}" for n, p, ok in above if not ok]
        lines.append(
            f"| {label} | {'met' if won else 'not met (' + ', '.join(failed) + ')'} | "
            f"{'met' if comply else 'not met'} | {'met' if sample_ok else 'not met'} | "
            + (
                "–"
                if not above
                else "met"
                if not below
                else f"not met (below at {', '.join(below)})"
            )
            + " |"
        )
    return lines


def costs(out: Path) -> str:
    """Wall and CPU seconds of the timed tleaf calls (OUT/times.tsv), by command."""
    path = out / "times.tsv"
    if not path.is_file():
        return ""
    kinds: dict = {}
    for line in path.read_text().splitlines():
        parts = line.split("\t")
        if len(parts) < 4:
            continue
        words = parts[3].split()
        kind = next(
            (
                " ".join(words[i : i + 2])
                for i, w in enumerate(words)
                if w in ("train-task", "eval")
            ),
            "other",
        )
        k = kinds.setdefault(kind, [0, 0.0, 0.0])
        k[0] += 1
        k[1] += float(parts[0])
        k[2] += float(parts[1]) + float(parts[2])
    return "; ".join(
        f"{kind}: {n} calls, {wall / 60:.1f} min wall, {cpu / 60:.1f} min CPU"
        for kind, (n, wall, cpu) in sorted(kinds.items())
    )


def record_lines(out: Path) -> list[str]:
    """The run's record (OUT/record.json, pipelines/mezini_data.py kb) as markdown lines: the
    prefix lengths and the longest suffix and where each came from, the constraints left out
    of the model and why; none without a record."""
    path = out / "record.json"
    if not path.is_file():
        return []
    record = load_json(path)
    lines = []
    for key, label in (("prefixes", "Prefix lengths"), ("max_suffix", "Longest suffix")):
        got = record.get(key)
        if got:
            data = (
                "" if str(got["value"]) == str(got["data"]) else f"; the data gives {got['data']}"
            )
            lines.append(f"- {label} {got['value']}: {got['from']}{data}.")
    published = record.get("published")
    if published:
        lines.append(
            f"- Their figures: the {published['rows']} rows of `{published['csv']}` for "
            f"{published['dataset']} (those at α {ALPHA:g} compared)."
        )
    kb = record.get("kb") or {}
    if kb:
        dropped = kb.get("dropped", [])
        lines.append(
            f"- The model: {kb.get('kept')} of the {kb.get('constraints')} constraints of "
            f"`{kb.get('model')}`"
            + (
                "; left out:"
                if dropped
                else ", every one (each names only activities the logs have)."
            )
        )
        for d in dropped:
            lines.append(f"  - line {d['line']}, {d['constraint']}: {d['why']}.")
    return lines


def section(
    out: Path,
    published: Path | None,
    settings: str = "",
    command: str = "",
    dataset: str | None = None,
) -> str:
    runs_by_noise = collect(out)
    if not runs_by_noise:
        raise SystemExit(f"{out}: no evaluations (OUT/n<noise>/s<seed>/eval-*/metrics.json)")
    noises = sorted(runs_by_noise)
    prefixes = prefixes_in(runs_by_noise)
    if not prefixes:
        raise SystemExit(f"{out}: its evaluations scored no suffixes (eval --prefix-lengths)")
    short = prefixes[:2]
    losses = losses_in(runs_by_noise)
    means = published_means(read_published(published, dataset)) if published else {}
    their_runs = max((n for _, _, n in means.values()), default=0)
    seeds = sorted({s for runs in runs_by_noise.values() for s in runs})
    lines: list[str] = []
    say = lines.append
    say(
        f"Seeds {', '.join(map(str, seeds))}; prefix lengths {', '.join(prefixes)}. A cell: the "
        "mean ± sd over the seeds of Mezini et al.'s trace similarity (1 − DL / longer length "
        "over prefix + suffix + an end symbol; eval next-activity's `trace_dl_similarity`), "
        "then the mean share of predicted cases that satisfy the Declare model. λ 0: the "
        "reference (no logic loss); a loss's column: its run with λ chosen on validation "
        "next-activity accuracy; `+ rules`: the same model decoded with the rules as a hard "
        "filter."
        + (
            f" Theirs: the mean of their {their_runs} runs at α {ALPHA:g}, similarity / "
            "satisfiability (– where their figures have no such noise level or prefix length)."
            if means
            else ""
        )
    )
    record = record_lines(out)
    if record:
        say("")
        say("**The run** (`record.json`):")
        say("")
        lines.extend(record)
    if settings:
        say("")
        say(f"Settings: {settings}.")
    if command:
        say("")
        say(f"Command: `{command}`")
    for strategy, ways, title in (
        ("greedy", GREEDY, "Greedy (argmax)"),
        ("temperature", SAMPLED, "Sampled at temperature 0.7"),
    ):
        variants = [("λ 0", "none", ways[0]), *knowledge_variants(losses, ways)]
        say("")
        say(f"**{title}:**")
        say("")
        lines.extend(table(runs_by_noise, variants, means, strategy, noises, prefixes))
    recount = short_prefixes(runs_by_noise, prefixes)
    if recount:
        shown = ", ".join(recount)
        say("")
        say(
            f"**Prefix {shown} as their code counts it** (trace similarity over all test "
            "cases: a case shorter than the prefix scores 1, its prefix holding the whole "
            "trace; above, a prefix length scores only the cases at least that long), greedy, "
            "then sampled:"
        )
        for strategy, ways in (("greedy", GREEDY), ("temperature", SAMPLED)):
            say("")
            variants = [("λ 0", "none", ways[0]), *knowledge_variants(losses, ways)]
            lines.extend(
                table(runs_by_noise, variants, means, strategy, noises, recount, their_count=True)
            )
    say("")
    say(
        "**Seeds where a knowledge variant beats its own seed's reference** (λ 0, greedy argmax) "
        "on trace similarity, strictly, greedy decoding:"
    )
    say("")
    variants = knowledge_variants(losses, GREEDY)
    head = ["noise", "prefix", *[v[0] for v in variants]]
    say("| " + " | ".join(head) + " |")
    say("|" + "---|" * len(head))
    for noise in noises:
        for prefix in short:
            row = [f"{noise} %", prefix]
            for _, variant, way in variants:
                w, n = wins(runs_by_noise[noise], variant, way, prefix)
                row.append(f"{w} of {n}")
            say("| " + " | ".join(row) + " |")
    if means:
        say("")
        say("**The goals**, per knowledge variant:")
        say("")
        lines.extend(verdicts(runs_by_noise, means, losses, prefixes))
    for lo in losses:
        grid = grid_of(runs_by_noise, lo)
        say("")
        say(
            f"**{lo}: the λ chosen on validation** (per seed) and every λ of the grid, "
            f"greedy without the rules, trace similarity at prefixes {' / '.join(short)} (mean "
            "over the seeds), and validation next-activity accuracy (mean):"
        )
        say("")
        head = ["noise", "λ chosen", *[f"λ {lam}" for lam in grid]]
        say("| " + " | ".join(head) + " |")
        say("|" + "---|" * len(head))
        for noise in noises:
            runs = runs_by_noise[noise]
            chosen = ", ".join(runs[s]["chosen"].get(lo, "–") for s in sorted(runs))
            row = [f"{noise} %", chosen]
            for lam in grid:
                got = [mean_sd(values(runs, f"{lo}@{lam}", p, "argmax")) for p in short]
                val = [runs[s]["val"].get(lo, {}).get(lam) for s in sorted(runs)]
                val = [v for v in val if v is not None]
                figures = " / ".join(f"{g[0]:.3f}" for g in got if g is not None)
                row.append(
                    "–"
                    if any(g is None for g in got)
                    else f"{figures} (val {statistics.fmean(val):.3f})"
                    if val
                    else figures
                )
            say("| " + " | ".join(row) + " |")
    spent = costs(out)
    if spent:
        say("")
        say(f"Cost (timed tleaf calls, one core each): {spent}.")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    j = sub.add_parser("join", help="one XES of a training log then a test log, and its split")
    j.add_argument("train", type=Path)
    j.add_argument("test", type=Path)
    j.add_argument("-o", "--out", type=Path, required=True)
    j.add_argument("--val", type=float, default=0.2, help="the share of TRAIN's last cases")
    r = sub.add_parser("report", help="the markdown section from OUT's evaluations")
    r.add_argument("out", type=Path)
    r.add_argument("--published", type=Path, help="their rows of paper_results.csv")
    r.add_argument("--dataset", help="the log whose rows of --published to read (its `dataset`)")
    r.add_argument("-o", "--output", type=Path, help="the section (default: stdout)")
    r.add_argument("--settings", default="")
    r.add_argument("--command-line", default="")
    args = parser.parse_args(argv)
    if args.command == "join":
        if not 0 < args.val < 1 or math.isnan(args.val):
            parser.error("--val: a share between 0 and 1")
        counts = join(args.train, args.test, args.out, args.val)
        print(f"{args.out}: train {counts[0]}, val {counts[1]}, test {counts[2]} cases")
        return 0
    text = section(args.out, args.published, args.settings, args.command_line, args.dataset)
    if args.output:
        args.output.write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
