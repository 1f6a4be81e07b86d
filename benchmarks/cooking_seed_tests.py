"""tleaf against the reference, seed by seed, from an `eval cooking` report.json.

    python benchmarks/cooking_seed_tests.py out/cooking/report/report.json [A B]

For variants A and B (default tleaf and none), on the demonstrated pool: at how many seeds A
first reached 90 % of the expert before B, after B, or at the same evaluation (a seed that never
got there counts as never; the runs are paired by seed: both lists in the report's seed order);
Wilcoxon's signed-rank test on the steps of the seeds where both got there; Fisher's exact test
on how many seeds of each reached it. The bootstrap interval of the ratio of medians is in the
report itself (`tleaf_over_none_median_steps_to_90`). scipy comes with scikit-learn, a dependency.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from scipy.stats import fisher_exact, wilcoxon


def main(path: str, a: str = "tleaf", b: str = "none") -> None:
    variants = json.loads(Path(path).read_text())["variants"]
    va, vb = variants[a], variants[b]
    if va["seeds"] != vb["seeds"]:
        sys.exit(f"{path}: {a} and {b} ran at different seeds; they cannot be paired")
    never = math.inf
    pairs = [
        (never if x is None else x, never if y is None else y)
        for x, y in zip(va["steps_to_90_per_seed"], vb["steps_to_90_per_seed"], strict=True)
    ]
    first = sum(x < y for x, y in pairs)
    later = sum(x > y for x, y in pairs)
    print(
        f"{len(pairs)} seeds: {a} first at {first}, {b} first at {later}, "
        f"same evaluation at {len(pairs) - first - later}"
    )
    both = [x - y for x, y in pairs if x < never and y < never]
    if any(both):
        print(
            f"Wilcoxon signed-rank over the {len(both)} seeds where both got there: "
            f"p = {wilcoxon(both).pvalue:.2f}"
        )
    reached = [sum(x < never for x in column) for column in zip(*pairs, strict=True)]
    table = [[r, len(pairs) - r] for r in reached]
    print(
        f"reached: {a} {reached[0]} of {len(pairs)}, {b} {reached[1]} of {len(pairs)}; "
        f"Fisher's exact p = {fisher_exact(table).pvalue:.2f}"
    )


if __name__ == "__main__":
    main(*sys.argv[1:])
