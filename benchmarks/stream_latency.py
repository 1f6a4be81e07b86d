"""Latency, throughput and memory of `tleaf predict RUN --follow` (docs/monitoring.md, "Live
stream"); not a test.

The bundled Helpdesk example as a live stream: its events in time order (cases interleaved, each
case's last event carrying the end mark), a run trained on it (an LSTM of 100 units), the rules
of examples/helpdesk.decl plus 100 Declare constraints mined from the log with `tleaf
mine-declare` (where the miner finds fewer, the rest are Declare constraints over the same
activities, named in the output), `--samples 0`, on one CPU core (the process pinned to core 0
and torch on one thread).

- per-event latency, p50 / p99: `StreamMonitor.feed_line` and the output line's JSON, i.e. the
  JSON in, each rule's state advanced, the verdicts, the next event (one LSTM step from the
  case's cached state), the JSON out; after a warm-up pass over the stream;
- throughput: events per second over the measured pass, and through the command itself
  (`tleaf predict --follow FILE --until-idle 0 -o out.jsonl`, its own count of seconds);
- memory per open case: N cases opened with their first events and kept open, measured by
  tracemalloc (Python's objects) and by the process's resident memory (torch's tensors too).

    python benchmarks/stream_latency.py [WORK_DIR] [--epochs 5] [--open 2000]
"""

from __future__ import annotations

import argparse
import csv
import gc
import itertools
import json
import os
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parent.parent
LOG = ROOT / "examples" / "event_logs" / "helpdesk-400.csv"
KB = ROOT / "examples" / "helpdesk.decl"
MINED = 100
PADDING = ("Response", "Precedence", "Responded Existence", "Not Co-Existence", "Succession")


def tleaf(*args: str) -> None:
    tool = Path(sys.executable).parent / "tleaf"
    subprocess.run([str(tool), *args, "-q"], check=True)


def constraints(path: Path) -> tuple[list[str], list[str]]:
    """(activity names, constraint lines) of a .decl (its `activity` lines and its templates;
    binds, attribute domains and comments left out)."""
    activities, rules = [], []
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("activity "):
            activities.append(line[len("activity ") :].strip())
        elif "[" in line and not line.lstrip().startswith("#"):
            rules.append(line.strip())
    return activities, rules


def rules_file(work: Path) -> tuple[Path, dict]:
    """examples/helpdesk.decl's constraints and MINED more: mined at the loosest thresholds,
    every template; padded with PADDING's templates over the log's activity pairs if short."""
    mined_path = work / "mined.decl"
    tleaf("mine-declare", str(work / "helpdesk.parquet"), "--templates", "all",
          "--min-support", "0.2", "--min-confidence", "0.2", "--min-activated", "1",
          "-o", str(mined_path))  # fmt: skip
    kb_activities, kb_rules = constraints(KB)
    activities, mined = constraints(mined_path)
    mined = [r for r in mined if r not in kb_rules][:MINED]
    found = len(mined)
    names = sorted(set(activities) | set(kb_activities))
    for template, (a, b) in itertools.product(PADDING, itertools.permutations(names, 2)):
        if len(mined) >= MINED:
            break
        line = f"{template}[{a}, {b}] | | |"
        if line not in mined and line not in kb_rules:
            mined.append(line)
    text = "".join(f"activity {n}\n" for n in names) + "\n".join(kb_rules + mined) + "\n"
    path = work / "rules.decl"
    path.write_text(text, encoding="utf-8")
    return path, {"helpdesk.decl": len(kb_rules), "mined": found, "padded": len(mined) - found}


def stream_lines(path: Path) -> list[str]:
    """The log's events as JSON lines in time order (file order breaks ties), each case's
    last event with the end mark."""
    with path.open(newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    last = {r["case:concept:name"]: i for i, r in enumerate(rows)}
    events = []
    for i, r in enumerate(rows):
        event = {
            "case": r["case:concept:name"],
            "activity": r["concept:name"],
            "timestamp": r["time:timestamp"],
        }
        if last[event["case"]] == i:
            event["end"] = True
        events.append(event)
    events.sort(key=lambda e: e["timestamp"])
    return [json.dumps(e) for e in events]


def rss() -> int:
    """Resident memory of this process, bytes."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def monitor_of(run: Path, rules: Path):
    from tleaf_cli.settings.next_activity import PredictSettings
    from tleaf_cli.tasks.next_activity.predict import Predictor
    from tleaf_cli.tasks.next_activity.stream import StreamMonitor

    return StreamMonitor(Predictor.load(run, PredictSettings(samples=0), rules))


def latency(run: Path, rules: Path, lines: list[str]) -> dict:
    monitor_of(run, rules)  # the warm-up: a pass over the whole stream, discarded
    warm = monitor_of(run, rules)
    for n, line in enumerate(lines, 1):
        json.dumps(warm.feed_line(line, n))
    monitor = monitor_of(run, rules)
    times = np.empty(len(lines))
    start = time.perf_counter()
    for n, line in enumerate(lines, 1):
        t = time.perf_counter()
        json.dumps(monitor.feed_line(line, n))
        times[n - 1] = time.perf_counter() - t
    total = time.perf_counter() - start
    rules_ = monitor.rules
    return {
        "rules": len(monitor.rule_names),
        "dfa_states": int(sum(d.num_states for d in rules_.dfas)) if rules_ else 0,
        "events": len(lines),
        "p50_ms": round(1000 * float(np.percentile(times, 50)), 3),
        "p99_ms": round(1000 * float(np.percentile(times, 99)), 3),
        "max_ms": round(1000 * float(times.max()), 3),
        "events_per_s": round(len(lines) / total),
    }


def memory(run: Path, rules: Path, lines: list[str], n: int) -> dict:
    """Bytes per open case: `n` cases opened with the events of the stream's first cases
    (renamed, so each is a case of its own; no end marks), kept open."""
    template = [json.loads(x) for x in lines[:400]]
    for e in template:
        e.pop("end", None)
    monitor = monitor_of(run, rules)
    for k, e in enumerate(template):  # warm the caches
        monitor.feed({**e, "case": f"warm{k}"})
    monitor.open.clear()
    gc.collect()
    before_rss = rss()
    tracemalloc.start()
    before = tracemalloc.take_snapshot()
    cases = sorted({e["case"] for e in template})
    events = 0
    for copy in range(n // len(cases) + 1):
        for e in template:
            if copy * len(cases) + cases.index(e["case"]) >= n:
                continue
            monitor.feed({**e, "case": f"{e['case']}#{copy}"})
            events += 1
    gc.collect()
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename"))
    opened = len(monitor.open)
    return {
        "open_cases": opened,
        "events_per_case": round(events / opened, 2),
        "tracemalloc_bytes_per_case": round(grown / opened),
        "rss_bytes_per_case": round((rss() - before_rss) / opened),
    }


def command(work: Path, run: Path, rules: Path, lines: list[str]) -> dict:
    """The command itself on the stream as a file, pinned to core 0: its own seconds."""
    events = work / "events.jsonl"
    events.write_text("\n".join(lines) + "\n", encoding="utf-8")
    out = work / "out.jsonl"
    tool = Path(sys.executable).parent / "tleaf"
    args = ["taskset", "-c", "0", str(tool), "predict", str(run), "--follow", str(events),
            "--until-idle", "0", "--rules", str(rules), "--samples", "0", "-o", str(out),
            "-q"]  # fmt: skip
    start = time.perf_counter()
    subprocess.run(args, check=True)
    wall = time.perf_counter() - start
    summary = json.loads((work / "out.summary.json").read_text())
    return {
        "command": "taskset -c 0 tleaf " + " ".join(args[4:]).replace(str(work) + "/", ""),
        "lines": summary["lines"],
        "written": summary["written"],
        "stream_seconds": summary["seconds"],
        "events_per_s": round(summary["lines"] / summary["seconds"]),
        "wall_seconds_with_startup": round(wall, 2),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("work", nargs="?", type=Path, default=Path("/tmp/tleaf-stream-bench"))
    parser.add_argument("--epochs", type=int, default=5)
    parser.add_argument("--open", type=int, default=2000)
    a = parser.parse_args()
    work = a.work
    work.mkdir(parents=True, exist_ok=True)
    os.sched_setaffinity(0, {0})
    torch.set_num_threads(1)
    cases = work / "helpdesk.parquet"
    if not cases.exists():
        tleaf("read-log", str(LOG), "-o", str(cases))
    run = work / "run"
    if not (run / "weights.pt").exists():
        tleaf("train-task", "next-activity", str(cases), "-o", str(run), "--epochs", str(a.epochs))
    rules, counts = rules_file(work)
    lines = stream_lines(LOG)
    load = os.getloadavg()
    report = {
        "machine": f"{os.cpu_count()} cores, load average {load[0]:.2f} at the start",
        "rules_file": counts,
        "stream (helpdesk.decl + 100 constraints)": latency(run, rules, lines),
        "stream (helpdesk.decl only)": latency(run, KB, lines),
        "memory": memory(run, rules, lines, a.open),
        "command": command(work, run, rules, lines),
    }
    report["load_average_at_the_end"] = round(os.getloadavg()[0], 2)
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
