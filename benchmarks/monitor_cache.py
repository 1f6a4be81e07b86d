"""The monitor-share cache against computing the shares: one DFA set, both ways, in the same
run.

    python benchmarks/monitor_cache.py out/mc/high/dfas.parquet [--slots 6] [--ranges 3]

Prints the seconds to compute every DFA's shares (`MonitorBank.of_dfa`, no cache), to compute
and write them (a cold cache), and to read them back (a warm cache, what every later train-meta
or evaluation over the same file pays), with the ratio, and checks the read shares equal the
computed ones bitwise. The cache folder is a temporary one, so the user's cache is untouched.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from tleaf_cli.data.dfa_table import dfa_from_row, read_dfas
from tleaf_cli.data.monitor_cache import monitor_shares
from tleaf_cli.logic.monitors import MonitorBank


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dfas", help="a dfas.parquet")
    parser.add_argument("--slots", type=int, default=6, help="atom slots (the pipeline's 6)")
    parser.add_argument("--ranges", type=int, default=3, help="length ranges (the pipeline's 3)")
    args = parser.parse_args()
    dfas = [dfa_from_row(r) for r in read_dfas(args.dfas).rows if r["error"] is None]
    bank = MonitorBank(args.slots, ranges=args.ranges)
    with tempfile.TemporaryDirectory() as folder:
        timed = {}
        for name, kwargs in (
            ("computed, no cache", {"use_cache": False}),
            ("computed and written (cold cache)", {"cache_dir": Path(folder)}),
            ("read back (warm cache)", {"cache_dir": Path(folder)}),
        ):
            start = time.perf_counter()
            timed[name] = (monitor_shares(dfas, bank, **kwargs), time.perf_counter() - start)
    shares = [s for s, _ in timed.values()]
    assert all(np.array_equal(shares[0], s) for s in shares[1:]), "cached shares differ"
    computed = timed["computed, no cache"][1]
    print(f"{args.dfas}: {len(dfas)} DFAs, {shares[0].nbytes / 1e6:.1f} MB of shares")
    for name, (_, seconds) in timed.items():
        print(f"  {name}: {seconds:.3f} s ({computed / seconds:.1f}x against computing)")


if __name__ == "__main__":
    main()
