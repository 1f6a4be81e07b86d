"""What the public API's argument checks cost: the exact loss (forward and backward) on a batch
of 64 sequences × 50 steps, this tree's code against a baseline tree's, in one run; and the
call's boundary alone (`losses.packed.rules_per_sequence`, where the checks run), whose
difference is the checks' own cost.

    python benchmarks/argument_checks.py BASELINE_TREE [--repeats 200] [--rounds 5]

BASELINE_TREE is a checkout of the code to compare with (e.g. `git worktree add /tmp/base
REV`); each round times both trees, one after the other (the order alternating), in fresh
subprocesses on one CPU thread, and the table gives the median per call over the rounds'
medians and the ratio (this / baseline).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent

# run inside a subprocess whose PYTHONPATH is the tree under test
TIMED = r"""
import json, sys, time
import torch
import tleaf_cli as tl

torch.set_num_threads(1)
vocab = [f"item{i}" for i in range(12)]
rules = tl.RuleSet(["(!item2 U item0) | G !item2", "F item11", "G(item3 -> F item4)"], vocab)
torch.manual_seed(0)
logits = torch.randn(64, 50, len(vocab), requires_grad=True)
lengths = torch.randint(20, 51, (64,))
repeats = int(sys.argv[1])
for _ in range(10):  # warm-up: compiled rule sets, packed tensors, allocator
    tl.logic_loss("exact", torch.log_softmax(logits, -1), rules, lengths).backward()
times = []
for _ in range(repeats):
    start = time.perf_counter()
    loss = tl.logic_loss("exact", torch.log_softmax(logits, -1), rules, lengths)
    loss.backward()
    times.append(time.perf_counter() - start)
# the boundary alone: the arguments' checks (and, in both trees, the rule sets' broadcast)
from tleaf_cli.losses.packed import rules_per_sequence

log_probs = torch.log_softmax(logits, -1).detach()
boundary = []
for _ in range(repeats):
    start = time.perf_counter()
    rules_per_sequence(log_probs, rules, lengths)
    boundary.append(time.perf_counter() - start)
print(json.dumps([times, boundary]))
"""


def time_tree(tree: Path, repeats: int) -> list[list[float]]:
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1"}
    out = subprocess.run(
        [sys.executable, "-c", TIMED, str(repeats)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd=tree,
    )
    return json.loads(out.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("baseline", type=Path, help="a checkout of the code to compare with")
    parser.add_argument("--repeats", type=int, default=200, help="timed calls per round")
    parser.add_argument("--rounds", type=int, default=5, help="rounds, each timing both trees")
    args = parser.parse_args()
    medians: dict[str, list[float]] = {"this": [], "baseline": []}
    boundary: dict[str, list[float]] = {"this": [], "baseline": []}
    trees = [("baseline", args.baseline.resolve()), ("this", HERE)]
    for r in range(args.rounds):  # the order alternates, so neither tree always runs first
        for name, tree in trees if r % 2 == 0 else trees[::-1]:
            loss, checks = time_tree(tree, args.repeats)
            medians[name].append(statistics.median(loss))
            boundary[name].append(statistics.median(checks))
    this, base = statistics.median(medians["this"]), statistics.median(medians["baseline"])
    at = {k: 1000 * statistics.median(v) for k, v in boundary.items()}
    print("| code | exact loss, 64 × 50 steps, forward + backward (ms) | its boundary (ms) |")
    print("|---|---|---|")
    print(f"| baseline ({args.baseline}) | {1000 * base:.2f} | {at['baseline']:.3f} |")
    print(f"| this tree | {1000 * this:.2f} | {at['this']:.3f} |")
    print(f"\nratio this / baseline: {this / base:.3f} (rounds: {args.rounds} × {args.repeats})")
    extra = at["this"] - at["baseline"]
    print(f"the checks' own cost: {extra:.3f} ms, {100 * extra / (1000 * base):.1f} % of a call")


if __name__ == "__main__":
    main()
