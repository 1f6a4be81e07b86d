"""Per-epoch training time of q_e, q_m and the action recogniser (none, exact, tleaf losses),
this tree against another (e.g. the landed commit), on the CPU and, where one is present, a GPU.

    git worktree add /tmp/tleaf-base <commit>
    python benchmarks/speed.py --baseline /tmp/tleaf-base [--out DIR] [--devices cpu cuda]
                               [--repeat 2 [--median]] [--embedders-only]

Every figure comes from the run's own `metrics.json` (`seconds` of each epoch: training only,
without evaluation), as the mean over the epochs after the first (with `--repeat N`, the
fastest of N such runs, or with `--median` their median, the trees taking turns); every
command runs in a fresh process with one torch thread (OMP_NUM_THREADS=1), the trees one
after the other on the same data, so the ratios compare like with like. Data (SYNTHETIC): the
Low tier, `--formulas` formulas with 20 traces each, as the Table I pipeline draws them;
activities as the action-recognition pipeline draws them (60 training videos), with a q
trained for one epoch on their rule sets (its quality does not matter for time). q_m runs the
default preset (best); the tleaf loss reads that q; the "labels" rows take each video's rule
set from its labels (fixed for the run) instead of from the model's predictions (new sets
every batch). Prints a markdown table: seconds per epoch for each tree and device, and the
baseline / this-tree ratio; for the action recogniser also each loss against `none`
(`--embedders-only`: q_e and q_m alone).

Each tree's commands run `python -P` with the tree first on PYTHONPATH, and before anything
runs the script checks that each tree's commands import that tree's own tleaf_cli: a baseline
that resolved to the checkout's package would time the code against itself.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
Q = ["--max-length", "20", "--pull", "0.02", "--monitor-ranges", "1", "--no-sphere"]
# the action recogniser's losses; "labels": each video's rule set from its labels, fixed for the
# run, so the loss's own cost without building rule sets for new predictions every batch
LOSSES = ("none", "exact", "tleaf", "exact labels", "tleaf labels")
NA = float("nan")  # a run that failed: "n/a" in the tables


def tleaf(tree: Path, *args: str) -> None:
    """`tleaf args` with the package of `tree`, one torch thread."""
    subprocess.run([*command(*args), "-q"], check=True, env=tree_env(tree), cwd=tree)


def command(*args: str) -> list[str]:
    """The tleaf command line for a tree's environment (`tree_env`). `python -P`: no working
    directory or script folder first on sys.path, so the package imported is the one first on
    PYTHONPATH, the tree's, wherever the command runs (a checkout's own package, found first
    from its folder, would time the checkout against itself)."""
    return [sys.executable, "-P", "-c", "from tleaf_cli.cli import main; main()", *args]


def tree_env(tree: Path) -> dict[str, str]:
    """The environment for `tree`'s commands: its package first on PYTHONPATH (before what the
    caller put there, e.g. wheels unpacked on a device machine), one torch thread."""
    path = os.pathsep.join(p for p in (str(tree), os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONPATH": path, "OMP_NUM_THREADS": "1"}


def package_of(tree: Path) -> Path | None:
    """Where `tree`'s commands import tleaf_cli from (None: they cannot import it)."""
    done = subprocess.run(
        [sys.executable, "-P", "-c", "import tleaf_cli; print(tleaf_cli.__file__)"],
        env=tree_env(tree), cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    return Path(done.stdout.strip()).resolve() if done.returncode == 0 else None


def check_tree(tree: Path) -> None:
    """Exit unless `tree`'s commands import the tree's own tleaf_cli."""
    where = package_of(tree)
    if where is None:
        sys.exit(f"error: {tree}: its commands cannot import tleaf_cli")
    if not where.is_relative_to(tree.resolve()):
        sys.exit(f"error: {tree}: its commands would import tleaf_cli from {where.parent}")


def epoch_seconds(run: Path) -> float:
    """Mean training seconds of a run's epochs after the first (the first pays warm-up)."""
    history = json.loads((run / "metrics.json").read_text())["history"]
    times = [h["seconds"] for h in history]
    return statistics.mean(times[1:] if len(times) > 1 else times)


def prepare(data: Path, tree: Path, formulas: int) -> None:
    """The Low tier and the activities with their q, made once with `tree` (reused)."""
    low, ar = data / "low", data / "ar"
    if not (low / "traces.parquet").exists():
        low.mkdir(parents=True, exist_ok=True)
        tleaf(
            tree,
            "gen-formulas",
            "--tier",
            "low",
            "-n",
            str(formulas),
            "--pairs",
            "20",
            "--seed",
            "0",
            "-o",
            str(low / "formulas.ltl"),
        )
        tleaf(tree, "compile-dfa", str(low / "formulas.ltl"), "-o", str(low / "dfas.parquet"))
        tleaf(
            tree,
            "gen-traces",
            str(low / "dfas.parquet"),
            "--per-formula",
            "20",
            "--split",
            "0.8,0.1,0.1",
            "--seed",
            "0",
            "-o",
            str(low / "traces.parquet"),
        )
    if not (ar / "meta" / "metrics.json").exists():
        ar.mkdir(parents=True, exist_ok=True)
        tleaf(
            tree,
            "gen-activities",
            "-o",
            str(ar / "activities.parquet"),
            "--kb-out",
            str(ar / "kb.ltl"),
            "--seed",
            "0",
        )
        tleaf(
            tree,
            "kb-extract",
            str(ar / "kb.ltl"),
            str(ar / "activities.parquet"),
            "-o",
            str(ar / "kb"),
        )
        tleaf(tree, "compile-dfa", str(ar / "kb.ltl"), "--one-hot", "-o", str(ar / "rules.parquet"))
        subprocess.run(  # exit 1: some rule set is short of traces; the others are written
            [
                *command(),
                "gen-traces",
                str(ar / "kb" / "dfas.parquet"),
                "--once-each",
                "--per-formula",
                "20",
                "--split",
                "0.8,0.1,0.1",
                "-o",
                str(ar / "traces.parquet"),
                "-q",
            ],
            env=tree_env(tree),
            cwd=tree,
        )
        tleaf(
            tree, "train-edge", str(ar / "rules.parquet"), "-o", str(ar / "edge"), "--epochs", "1"
        )
        tleaf(
            tree,
            "train-meta",
            str(ar / "kb" / "dfas.parquet"),
            str(ar / "traces.parquet"),
            "--edge",
            str(ar / "edge"),
            "-o",
            str(ar / "meta"),
            "--epochs",
            "1",
            *Q,
        )


def measure(
    tree: Path, name: str, data: Path, device: str, epochs: int, recognisers: bool = True
) -> dict[str, float]:
    """Seconds per epoch of every trainer with `tree`'s code on `device` (without the action
    recogniser's unless `recognisers`)."""
    low, ar, runs = data / "low", data / "ar", data / "runs" / f"{name}-{device}"
    shutil.rmtree(runs, ignore_errors=True)  # fresh runs (a model folder is never overwritten)
    common = ["--device", device]
    tleaf(
        tree,
        "train-edge",
        str(low / "dfas.parquet"),
        "-o",
        str(runs / "edge"),
        "--epochs",
        str(epochs),
        *common,
    )
    # q_m reads this tree's q_e, so each tree's q_m has the same kind of input
    tleaf(
        tree,
        "train-meta",
        str(low / "dfas.parquet"),
        str(low / "traces.parquet"),
        "--edge",
        str(runs / "edge"),
        "-o",
        str(runs / "meta"),
        "--epochs",
        str(epochs),
        *common,
    )
    out = {"q_e": epoch_seconds(runs / "edge"), "q_m": epoch_seconds(runs / "meta")}
    for model in ("lstm", "tcn") if recognisers else ():
        for name in LOSSES:
            loss, _, source = name.partition(" ")  # "tleaf labels": rule sets from the labels
            run = runs / f"{model}-{name.replace(' ', '-')}"
            q = ["--embedder", str(ar / "meta")] if loss == "tleaf" else []
            q += ["--formula-from", source] if source else []
            try:
                tleaf(
                    tree, *recogniser_args(ar, model, loss, 2 * epochs), *q, "-o", str(run), *common
                )
            except subprocess.CalledProcessError:  # e.g. an older tree cannot read this q
                out[f"{model} {name}"] = NA
                continue
            out[f"{model} {name}"] = epoch_seconds(run)
    return out


def shown(value: float, spec: str, unit: str = "") -> str:
    """A figure as the tables print it; n/a for a failed run's NaN."""
    return "n/a" if math.isnan(value) else f"{value:{spec}}{unit}"


def recogniser_args(ar: Path, model: str, loss: str, epochs: int) -> list[str]:
    """`tleaf train-task action-recognition` on the prepared activities for `epochs` epochs
    (no early stop): the recogniser runs of this benchmark and of op_count.py."""
    return [
        "train-task",
        "action-recognition",
        str(ar / "activities.parquet"),
        "--kb",
        str(ar / "kb.ltl"),
        "--model",
        model,
        "--logic-loss",
        loss,
        "--epochs",
        str(epochs),
        "--patience",
        str(epochs),
    ]


def table(results: dict[tuple[str, str], dict[str, float]], devices: list[str]) -> str:
    trees = list(dict.fromkeys(t for t, _ in results))
    # with both devices: each tree's GPU speed-up over one CPU thread of the same machine
    gpu = [t for t in trees if (t, "cpu") in results and (t, "cuda") in results]
    rows = [
        "| trainer | "
        + " | ".join(f"{t} {d}" for t, d in results)
        + " | baseline / this |"
        + "".join(f" {t}: cpu / cuda |" for t in gpu),
        "|---|" + "---|" * (len(results) + 1 + len(gpu)),
    ]
    for key in next(iter(results.values())):
        cells = [shown(r[key], ".3f") for r in results.values()]
        ratios = [
            shown(results[("baseline", d)][key] / results[("this", d)][key], ".2f", f"x ({d})")
            for d in devices
            if ("baseline", d) in results and ("this", d) in results
        ]
        speedups = [
            shown(results[(t, "cpu")][key] / results[(t, "cuda")][key], ".1f", "x") for t in gpu
        ]
        rows.append(
            f"| {key} | " + " | ".join(cells) + f" | {', '.join(ratios)} |"
            + "".join(f" {x} |" for x in speedups)
        )  # fmt: skip
    if "lstm none" not in next(iter(results.values())):  # --embedders-only
        return "\n".join(rows)
    rows.append("")
    rows.append("Each loss's epoch against `none` (same model, tree and device):")
    rows.append("")
    losses = LOSSES[1:]
    rows.append(
        "| tree, device | "
        + " | ".join(f"{m} {loss}" for m in ("lstm", "tcn") for loss in losses)
        + " |"
    )
    rows.append("|---|" + "---|" * 2 * len(losses))
    for (tree, device), r in results.items():
        ratios = [
            shown(r[f"{m} {loss}"] / r[f"{m} none"], ".2f", "x")
            for m in ("lstm", "tcn")
            for loss in losses
        ]
        rows.append(f"| {tree}, {device} | " + " | ".join(ratios) + " |")
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, help="another tleaf tree (a git worktree)")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "bench-speed")
    parser.add_argument("--this", type=Path, default=ROOT, help="the tree to time [this one]")
    parser.add_argument("--formulas", type=int, default=1000, help="Low-tier formulas")
    parser.add_argument(
        "--epochs",
        type=int,
        default=3,
        help="epochs of q_e and q_m (twice that for the action recogniser)",
    )
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="run every trainer this many times, the trees taking turns, and keep each "
        "figure's fastest run (the host's speed drifts between runs)",
    )
    parser.add_argument(
        "--median",
        action="store_true",
        help="with --repeat: keep each figure's median over the runs, not the fastest",
    )
    parser.add_argument(
        "--devices",
        nargs="+",
        default=None,
        help="cpu and/or cuda [default: cpu, and cuda where present]",
    )
    parser.add_argument(
        "--embedders-only",
        action="store_true",
        help="time q_e and q_m only, not the action recogniser",
    )
    args = parser.parse_args()
    devices = args.devices
    if devices is None:
        import torch

        devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
    out = args.out.resolve()
    trees = [("this", args.this.resolve())]
    trees += [("baseline", args.baseline.resolve())] if args.baseline else []
    for _, tree in trees:
        check_tree(tree)
    prepare(out / "data", args.this.resolve(), args.formulas)
    runs: dict[tuple[str, str], list[dict[str, float]]] = {}
    for _ in range(args.repeat):
        for device in devices:
            for name, tree in trees:
                run = measure(
                    tree, name, out / "data", device, args.epochs, not args.embedders_only
                )
                print(name, device, json.dumps(run), flush=True)
                runs.setdefault((name, device), []).append(run)
    keep = statistics.median if args.median else min
    results = {
        where: {key: keep([r[key] for r in every]) for key in every[0]}
        for where, every in runs.items()
    }
    (out / "speed.json").write_text(
        json.dumps({f"{t} {d}": r for (t, d), r in results.items()}, indent=2)
    )
    print(table(results, devices))


if __name__ == "__main__":
    main()
