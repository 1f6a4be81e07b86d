"""Per-stage wall and CPU seconds of a pipeline run through `pipelines/timed-tleaf`.

    TLEAF_TIMES=$PWD/times.tsv make -f pipelines/model_checking.mk TLEAF=$PWD/pipelines/timed-tleaf
    python benchmarks/stage_times.py times.tsv

Prints a markdown table: one row per stage (the tleaf subcommand; for train-meta and eval,
with the row of q's `meta-<row>` folder: dfa, paper, syntax; for train-task runs written to
`runs/<variant>-seed<s>`, as pipelines/cooking.mk does, with the variant), the number of calls,
and one column pair per tier (the path component after the pipeline's out directory: low,
moderate, high), wall and CPU (user + system) seconds summed over the calls.
"""

from __future__ import annotations

import csv
import re
import sys
from collections import defaultdict

TIERS = ("low", "moderate", "high")


def stage_of(command: str) -> tuple[str, str]:
    words = command.split()
    stage = words[1] if words[1] != "eval" else f"eval {words[2]}"
    # the row of the model-checking pipeline: its q's folder, meta-<row> (eval reads it)
    kind = re.search(r"/meta-(\w+)", command)
    if kind and stage in ("train-meta", "eval model-checking"):
        stage += f" ({kind.group(1)})"
    variant = re.search(r"/runs/([\w.]+)-seed\d+", command)
    if variant and stage == "train-task":
        stage += f" ({variant.group(1)})"
    tier = next((t for t in TIERS if f"/{t}/" in command), "all")
    return stage, tier


def main(path: str) -> None:
    wall: dict[tuple[str, str], float] = defaultdict(float)
    cpu: dict[tuple[str, str], float] = defaultdict(float)
    calls: dict[str, int] = defaultdict(int)
    order: list[str] = []
    with open(path) as f:
        for row in csv.reader(f, delimiter="\t"):
            if len(row) != 4:  # /usr/bin/time's "Command exited with non-zero status" lines
                continue
            stage, tier = stage_of(row[3])
            wall[stage, tier] += float(row[0])
            cpu[stage, tier] += float(row[1]) + float(row[2])
            calls[stage] += 1
            if stage not in order:
                order.append(stage)
    tiers = [t for t in (*TIERS, "all") if any(k[1] == t for k in wall)]
    print("| stage | calls | " + " | ".join(f"{t} wall / CPU s" for t in tiers) + " |")
    print("|---|---|" + "---|" * len(tiers))
    for stage in order:
        cells = [
            f"{wall[stage, t]:.0f} / {cpu[stage, t]:.0f}" if (stage, t) in wall else "–"
            for t in tiers
        ]
        print(f"| {stage} | {calls[stage]} | " + " | ".join(cells) + " |")
    total_wall, total_cpu = sum(wall.values()), sum(cpu.values())
    print(
        f"\nsum over calls: {total_wall:.0f} s wall (process time, calls overlap under -j), "
        f"{total_cpu:.0f} s CPU"
    )


if __name__ == "__main__":
    main(sys.argv[1])
