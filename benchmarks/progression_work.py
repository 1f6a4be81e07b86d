"""Progression's work budget under `--engine auto` (`logic/compile.py`, AUTO_WORK): the units of
work progression counts against the time they take, over the formula sets tleaf compiles.

Progression counts its work (`logic/progression.py`, "Limits") instead of timing it, so that a
formula takes the same route (progression, or MONA past the budget) on any machine under any
load. This script is how the budget was chosen: for every direct construction (one progression
over at most 4 atoms, or over a formula that does not split) of every formula of the sets below,
it records the units counted and the CPU seconds the construction took (best of 3, budget off;
CPU time, not wall time, so that other work on the machine skews the figures less), and prints

1. microseconds per unit, by how long a construction took: the budget that matches a 10 ms
   clock (the rule before, AUTO_SECONDS = 0.01) is 10 ms over the median;
2. for some budgets, the constructions routed otherwise than by the 10 ms clock: under 10 ms but
   sent to MONA ("fast sent"), over 10 ms but kept ("slow kept");
3. per set, with the budget in the code: formulas that go to MONA, and the CPU seconds compiling
   the whole set (`compile_formula` in this process, MONA's processes included) takes under
   `--engine auto`, `progression` (no budget) and `mona`.

The sets: random formulas as `tleaf gen-formulas` draws its candidates (tiers low: 3 atoms size
10, moderate: 3 atoms size 20, high: 6 atoms size 20; powerset), benchmark set 1 of
compile_bench.py (3 atoms, size 10..20), every Declare constraint mined from
examples/event_logs/helpdesk-400.csv at any support (one-hot and powerset; all ten templates
tleaf mines), the knowledge bases examples/kitchen.kb.ltl and examples/cooking_rules.ltl, and
the rules of a `tleaf gen-activities` knowledge base with `tleaf kb-extract`'s per-video
conjunctions of them (one-hot), what the action-recognition pipeline compiles.

    python benchmarks/progression_work.py            # ~3 min on 2 cores
    python benchmarks/progression_work.py --n 100    # fewer random formulas per tier
"""

from __future__ import annotations

import argparse
import contextlib
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import pyarrow.parquet as pq

from tleaf_cli.data.formula_files import read_formulas
from tleaf_cli.data.random_formulas import random_formula
from tleaf_cli.logic import progression
from tleaf_cli.logic.alphabet import Alphabet, AlphabetKind
from tleaf_cli.logic.compile import AUTO_WORK, Engine, by_progression, compile_formula
from tleaf_cli.logic.formulas import atoms, parse
from tleaf_cli.logic.mona import MonaError

ROOT = Path(__file__).resolve().parent.parent
CLOCK = 0.010  # the seconds budget AUTO_WORK replaces
Formulas = list[tuple[str, AlphabetKind]]


def tleaf(*args: str | Path) -> None:
    """Run a tleaf command quietly; exit with its output when it fails."""
    binary = Path(sys.executable).parent / "tleaf"
    proc = subprocess.run([str(binary), *map(str, args), "-q"], capture_output=True, text=True)
    if proc.returncode not in (0, 1):
        sys.exit(f"tleaf {' '.join(map(str, args))} failed:\n{proc.stdout}{proc.stderr}")


def from_file(path: Path, kind: AlphabetKind) -> Formulas:
    return [(s.text, kind) for s in read_formulas(path) if s.problem is None]


def formula_sets(n: int, folder: Path) -> dict[str, Formulas]:
    """The sets named in the module docstring, by name."""
    sets: dict[str, Formulas] = {}
    for tier, n_atoms, size in (("low", 3, 10), ("moderate", 3, 20), ("high", 6, 20)):
        rng = random.Random(0)
        names = [chr(ord("a") + k) for k in range(n_atoms)]
        sets[f"gen-formulas {tier}"] = [
            (random_formula(rng, names, size), "powerset") for _ in range(n)
        ]
    rng = random.Random(0)
    sets["compile_bench set 1"] = [
        (random_formula(rng, ["a", "b", "c"], rng.randint(10, 20)), "powerset") for _ in range(n)
    ]
    cases, mined = folder / "cases.parquet", folder / "mined.ltl"
    tleaf("read-log", ROOT / "examples/event_logs/helpdesk-400.csv", "-o", cases)
    loose = ["--min-support", "0", "--min-confidence", "0", "--min-joint-support", "0"]
    tleaf("mine-declare", cases, "-o", mined, *loose)
    for kind in ("one-hot", "powerset"):
        sets[f"mined Declare, {kind}"] = from_file(mined, kind)
    sets["kitchen.kb.ltl"] = from_file(ROOT / "examples/kitchen.kb.ltl", "one-hot")
    sets["cooking_rules.ltl"] = from_file(ROOT / "examples/cooking_rules.ltl", "powerset")
    data, kb, extracted = folder / "activities.parquet", folder / "kb.ltl", folder / "kbx"
    tleaf("gen-activities", "-o", data, "--kb-out", kb, "--feature-dim", "4", "--seed", "0")
    tleaf("kb-extract", kb, data, "-o", extracted, "--no-cache")
    sets["gen-activities kb rules"] = from_file(kb, "one-hot")
    rows = pq.read_table(extracted / "dfas.parquet", columns=["formula"]).to_pylist()
    sets["kb-extract conjunctions"] = [(r["formula"], "one-hot") for r in rows]
    return sets


def constructions(text: str, kind: AlphabetKind) -> list[tuple[float, int]]:
    """(seconds, units of work) of each direct construction of `text`, best of 3 by total time,
    with no work budget (the state and total-work limits stay)."""
    found: list[tuple[float, int]] = []
    real: Callable = progression._Progression.dfa

    def timed(self, root, alphabet):
        before, start = self.limits.work_done, time.thread_time()
        try:
            return real(self, root, alphabet)
        finally:
            found.append((time.thread_time() - start, self.limits.work_done - before))

    formula = parse(text)
    letters = Alphabet(atoms(formula), kind)
    best: list[tuple[float, int]] | None = None
    progression._Progression.dfa = timed  # type: ignore[method-assign]
    try:
        for _ in range(3):
            found.clear()
            with contextlib.suppress(progression.TooLarge):
                progression.progression_dfa(formula, letters)
            if best is None or sum(t for t, _ in found) < sum(t for t, _ in best):
                best = list(found)
            if sum(t for t, _ in found) > 0.5:
                break
    finally:
        progression._Progression.dfa = real  # type: ignore[method-assign]
    return best or []


def quantile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def cpu_seconds() -> float:
    """CPU seconds of this process and of its children that ended (MONA's runs)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def set_seconds(formulas: Formulas, engine: Engine) -> tuple[float, int]:
    """(CPU seconds to compile every formula with `engine`, MONA's processes included; formulas
    that failed: past progression's limits under "progression", or MONA's)."""
    failed = 0
    start = cpu_seconds()
    for text, kind in formulas:
        try:
            compile_formula(text, kind, engine=engine)
        except (progression.TooLarge, MonaError):
            failed += 1
    return cpu_seconds() - start, failed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=600, help="random formulas per random set")
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPUs, load average at start {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory(prefix="tleaf-work-") as tmp:
        sets = formula_sets(args.n, Path(tmp))
    runs = {name: [constructions(t, k) for t, k in formulas] for name, formulas in sets.items()}
    points = [p for per_set in runs.values() for per_formula in per_set for p in per_formula]
    print(f"{sum(map(len, sets.values()))} formulas, {len(points)} direct constructions")

    print("\n1. microseconds (CPU) per unit of work, by the construction's CPU time")
    print("| construction took | constructions | median | 10th percentile | 90th percentile |")
    print("|---|---:|---:|---:|---:|")
    for lo, hi in ((0.001, 0.005), (0.005, 0.02), (0.02, 0.2), (0.2, 60.0)):
        rates = [1e6 * t / w for t, w in points if lo <= t < hi and w]
        if rates:
            cells = [statistics.median(rates), quantile(rates, 0.1), quantile(rates, 0.9)]
            span = f"{1000 * lo:g} to {1000 * hi:g} ms"
            print(f"| {span} | {len(rates)} | " + " | ".join(f"{c:.3f}" for c in cells) + " |")
    near = [t / w for t, w in points if 0.005 <= t < 0.02 and w]
    print(f"10 ms over the median of 5 to 20 ms: {CLOCK / statistics.median(near):,.0f} units")

    print(f"\n2. routed otherwise than by the {1000 * CLOCK:g} ms clock, of {len(points)}")
    print("| budget (units) | fast sent to MONA | slow kept |")
    print("|---:|---:|---:|")
    for budget in sorted({5_000, 10_000, AUTO_WORK, 20_000, 40_000}):
        fast_sent = sum(w > budget and t <= CLOCK for t, w in points)
        slow_kept = sum(w <= budget and t > CLOCK for t, w in points)
        print(f"| {budget:,}{' (AUTO_WORK)' if budget == AUTO_WORK else ''} | {fast_sent} | "
              f"{slow_kept} |")  # fmt: skip

    print(f"\n3. per set, AUTO_WORK = {AUTO_WORK:,}: CPU seconds to compile the set")
    print("(failed: past progression's 2,000 states, or MONA's limits)")
    print("| set | formulas | auto: to MONA | auto s | progression s (failed) | mona s (failed) |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, formulas in sets.items():
        to_mona = sum(by_progression(parse(t), k, "auto") is None for t, k in formulas)
        (auto, _), *others = [set_seconds(formulas, e) for e in ("auto", "progression", "mona")]
        cells = " | ".join(f"{s:.2f} ({failed})" for s, failed in others)
        print(f"| {name} | {len(formulas)} | {to_mona} | {auto:.2f} | {cells} |")
    print(f"\nload average at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
