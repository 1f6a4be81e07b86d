"""Operators launched per training batch of q_e, q_m and the action recogniser (none, exact,
tleaf losses), this tree against another (e.g. an older commit), counted under torch's profiler
on the CPU: the shape of the work, which decides speed on a GPU (a launch per operator) and is the
same on every machine.

    git worktree add /tmp/tleaf-base <commit>
    python benchmarks/op_count.py --baseline /tmp/tleaf-base [--out DIR] [--formulas 300]
                                  [--only q_e q_m lstm tcn]

Each trainer runs its ordinary command (`tleaf train-edge`, `train-meta`, `train-task
action-recognition`) in a fresh process with the tree's package and one torch thread; a hook
after every optimiser step starts the profiler after `--skip` steps, marks each step, and stops
after `--batches` more. A batch's count is the aten operators recorded between two optimiser
steps (its graph assembly, forward, backward and Adam step); the figure is the median over the
batches (a batch that crosses an epoch's end also holds that epoch's evaluation: the median
leaves it out). Two counts: every aten call, and the leaf calls (no aten call inside them: the
ones that do the work, what a GPU launches as kernels, give or take views). The data are
`benchmarks/speed.py`'s, made once with this tree (`--formulas` Low formulas, the
activities and their q), so both trees read the same files. Prints the CPU, then a markdown
table: operators per batch for each tree and the baseline / this ratio. With OP_COUNT_TOP=N
each figure also lists its N most frequent operators, with OP_COUNT_TIME=N the N that took the
most CPU time (share of the aten operators' own time, profiler overhead included).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import statistics
import subprocess
import sys
from pathlib import Path

import speed

ROOT = Path(__file__).resolve().parents[1]
MARK = "__optimiser_step__"


def cpu_description() -> str:
    """The CPU's model, its vector extensions (/proc/cpuinfo flags) and what torch uses."""
    import torch

    model, flags = platform.processor() or "unknown", set()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name":
                model = value.strip()
            elif key.strip() == "flags":
                flags = set(value.split())
    vector = sorted(f for f in flags if f.startswith(("avx", "amx", "sse4", "fma")))
    capability = torch.backends.cpu.get_cpu_capability()
    return f"{model}; vector extensions: {' '.join(vector) or 'none read'}; torch uses {capability}"


def count_in_process(skip: int, batches: int, args: list[str]) -> None:
    """Run `tleaf args` here, profile optimiser steps skip..skip+batches, print the counts as
    one JSON line and leave (the rest of the training is not needed)."""
    import torch
    from torch.optim.optimizer import register_optimizer_step_post_hook

    from tleaf_cli.cli import main

    profiler = torch.profiler.profile(activities=[torch.profiler.ProfilerActivity.CPU])
    steps = [0]

    def after_step(*_: object) -> None:
        steps[0] += 1
        if steps[0] == skip:
            profiler.start()
        elif skip < steps[0] < skip + batches:
            with torch.profiler.record_function(MARK):
                pass
        elif steps[0] == skip + batches:
            profiler.stop()
            print(json.dumps(per_batch(profiler.events())), flush=True)
            os._exit(0)

    register_optimizer_step_post_hook(after_step)
    sys.argv = ["tleaf", *args, "-q"]
    with contextlib.suppress(SystemExit):
        main()
    raise SystemExit(f"training ended after {steps[0]} optimiser steps; fewer than asked")


def per_batch(events) -> dict[str, float]:
    """Median aten calls and leaf aten calls between consecutive marks."""
    marks = sorted(e.time_range.start for e in events if e.name == MARK)
    ops = [e for e in events if e.name.startswith("aten::")]
    bounds = [float("-inf"), *marks, float("inf")]
    every = [0] * (len(bounds) - 1)
    leaf = [0] * (len(bounds) - 1)
    for e in ops:
        k = next(i for i in range(len(bounds) - 1) if e.time_range.start < bounds[i + 1])
        every[k] += 1
        leaf[k] += not any(c.name.startswith("aten::") for c in e.cpu_children)
    names: dict[str, int] = {}
    for e in ops:
        names[e.name] = names.get(e.name, 0) + 1
    top = sorted(names.items(), key=lambda kv: -kv[1])[: int(os.environ.get("OP_COUNT_TOP", 0))]
    out = {"ops": statistics.median(every), "leaf": statistics.median(leaf)}
    if top:  # the most frequent operators, per batch on average (OP_COUNT_TOP=N)
        out["top"] = {name: round(n / len(every), 1) for name, n in top}
    slowest = int(os.environ.get("OP_COUNT_TIME", 0))
    if slowest:  # the operators that took the most CPU time (OP_COUNT_TIME=N): their share
        spent: dict[str, float] = {}
        for e in ops:
            spent[e.name] = spent.get(e.name, 0.0) + e.self_cpu_time_total
        total = sum(spent.values()) or 1.0
        ranked = sorted(spent.items(), key=lambda kv: -kv[1])[:slowest]
        out["cpu_time_share"] = {name: round(t / total, 3) for name, t in ranked}
    return out


def count(tree: Path, skip: int, batches: int, *args: str) -> dict[str, float]:
    """`count_in_process` in a fresh process with `tree`'s package and one torch thread."""
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1"}
    command = [sys.executable, __file__, "--inside", str(skip), str(batches), "--", *args]
    done = subprocess.run(command, env=env, cwd=tree, capture_output=True, text=True)
    if done.returncode:  # e.g. an older tree that cannot read this tree's q: no figure
        print(done.stderr.strip().splitlines()[-1], file=sys.stderr)
        return {"ops": float("nan"), "leaf": float("nan")}
    return json.loads(done.stdout.strip().splitlines()[-1])


TRAINERS = ("q_e", "q_m", "lstm", "tcn")


def measure(
    tree: Path, name: str, data: Path, batches: int, only: tuple[str, ...] = TRAINERS
) -> dict[str, dict[str, float]]:
    """Operators per batch of every trainer in `only` with `tree`'s code."""
    low, ar, runs = data / "low", data / "ar", data / "runs" / f"ops-{name}"
    edge = runs / "edge"
    if "q_m" in only and not (edge / "weights.pt").exists():  # q_m reads this tree's q_e
        speed.tleaf(tree, "train-edge", str(low / "dfas.parquet"), "-o", str(edge), "--epochs", "1")
    out = {}
    if "q_e" in only:
        out["q_e"] = count(
            tree,
            3,
            batches,
            "train-edge",
            str(low / "dfas.parquet"),
            "-o",
            str(runs / "edge-count"),
            "--epochs",
            "1",
        )
    if "q_m" in only:
        out["q_m"] = count(
            tree,
            3,
            batches,
            "train-meta",
            str(low / "dfas.parquet"),
            str(low / "traces.parquet"),
            "--edge",
            str(edge),
            "-o",
            str(runs / "meta-count"),
            "--epochs",
            "2",
        )
    for model in [m for m in ("lstm", "tcn") if m in only]:
        for loss in ("none", "exact", "tleaf"):
            q = ["--embedder", str(ar / "meta")] if loss == "tleaf" else []
            out[f"{model} {loss}"] = count(
                tree,
                2,
                batches,
                *speed.recogniser_args(ar, model, loss, 20),
                *q,
                "-o",
                str(runs / f"{model}-{loss}"),
            )
    return out


def table(this: dict, baseline: dict | None) -> str:
    head = "| trainer | this: aten ops | this: leaf ops |"
    rule = "|---|---|---|"
    if baseline is not None:
        head += " baseline: aten ops | baseline: leaf ops | baseline / this (leaf) |"
        rule += "---|---|---|"
    rows = [head, rule]
    for key, r in this.items():
        cells = f"| {key} | {r['ops']:.0f} | {r['leaf']:.0f} |"
        if baseline is not None:
            b = baseline[key]
            cells += f" {b['ops']:.0f} | {b['leaf']:.0f} | {b['leaf'] / r['leaf']:.1f}x |"
        rows.append(cells)
    return "\n".join(rows)


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--inside":  # the child process of `count`
        count_in_process(int(sys.argv[2]), int(sys.argv[3]), sys.argv[5:])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, help="another tleaf tree (a git worktree)")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "bench-ops")
    parser.add_argument("--this", type=Path, default=ROOT, help="the tree to count [this one]")
    parser.add_argument("--formulas", type=int, default=300, help="Low-tier formulas")
    parser.add_argument("--batches", type=int, default=8, help="batches counted per trainer")
    parser.add_argument(
        "--only",
        nargs="+",
        choices=TRAINERS,
        default=list(TRAINERS),
        help="count these trainers only (lstm, tcn: all three losses) [all]",
    )
    args = parser.parse_args()
    only = tuple(args.only)
    print("CPU:", cpu_description(), flush=True)
    out = args.out.resolve()
    speed.prepare(out / "data", args.this.resolve(), args.formulas)
    this = measure(args.this.resolve(), "this", out / "data", args.batches, only)
    print("this", json.dumps(this), flush=True)
    baseline = None
    if args.baseline:
        baseline = measure(args.baseline.resolve(), "baseline", out / "data", args.batches, only)
        print("baseline", json.dumps(baseline), flush=True)
    (out / "op_count.json").write_text(json.dumps({"this": this, "baseline": baseline}, indent=2))
    print(table(this, baseline))


if __name__ == "__main__":
    main()
