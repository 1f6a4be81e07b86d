"""DFAs as graph files for graph tools: networkx graphs, GraphML, and Graphviz DOT."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess
from collections import Counter
from pathlib import Path

import networkx as nx

from tleaf_cli.data.artifacts import atomic_path, write_text_atomic
from tleaf_cli.errors import InputError, TleafError

_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]")


def row_to_networkx(row: dict) -> nx.DiGraph:
    """A compiled `dfas.parquet` row as a DiGraph: node attrs initial/accepting, edge guard/cnf."""
    g = nx.DiGraph(
        formula_id=row["formula_id"],
        formula=row["formula"],
        alphabet=row["alphabet"],
        atoms=" ".join(row["atoms"]),
    )
    accepting = set(row["accepting"])
    for s in range(row["num_states"]):
        g.add_node(s, initial=s == row["initial"], accepting=s in accepting)
    for e in row["edges"]:
        g.add_edge(e["src"], e["dst"], guard=e["guard"], cnf=json.dumps(e["cnf"]))
    return g


def row_to_dot(row: dict) -> str:
    """Graphviz DOT text: accepting states double circles, an arrow into the initial state."""
    accepting = set(row["accepting"])
    lines = [
        f"digraph {_dot_id(row['formula_id'])} {{",
        "  rankdir=LR;",
        f"  label={_quote(row['formula'])}; labelloc=t;",
        '  node [shape=circle, fontname="Helvetica"]; edge [fontname="Courier"];',
        '  __start [shape=point, label=""];',
    ]
    for s in range(row["num_states"]):
        shape = "doublecircle" if s in accepting else "circle"
        lines.append(f"  {s} [shape={shape}];")
    lines.append(f"  __start -> {row['initial']};")
    for e in row["edges"]:
        lines.append(f"  {e['src']} -> {e['dst']} [label={_quote(e['guard'])}];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def write_graph_files(rows: list[dict], directory: str | Path) -> int:
    """`<id>.graphml` and `<id>.dot` for every compiled row; returns how many DFAs were written."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    stems = graph_file_stems([row["formula_id"] for row in rows])  # failed rows too: stable
    written = 0
    for row, stem in zip(rows, stems, strict=True):
        if row["error"] is not None:
            continue
        tmp = atomic_path(directory / f"{stem}.graphml")
        try:
            nx.write_graphml(row_to_networkx(row), tmp)
            tmp.replace(directory / f"{stem}.graphml")
        finally:
            tmp.unlink(missing_ok=True)
        write_text_atomic(directory / f"{stem}.dot", row_to_dot(row))
        written += 1
    return written


def graph_file_stems(ids: list[str]) -> list[str]:
    """A file name stem per formula id, no two the same even on a case-insensitive file system.

    An id keeps its own name, unsafe characters replaced by `_`; ids whose names would meet
    (`a/b` and `a_b`, `Rule` and `rule`) each get `-` and 8 hex digits of a hash of the id, so
    no graph file silently replaces another and each id always gets the same name.
    """
    plain = [_UNSAFE.sub("_", fid) for fid in ids]
    uses = Counter(stem.casefold() for stem in plain)
    stems = [
        stem if uses[stem.casefold()] == 1 else f"{stem}-{_short_hash(fid)}"
        for fid, stem in zip(ids, plain, strict=True)
    ]
    taken = Counter(stem.casefold() for stem in stems)
    clash = next((stem for stem in stems if taken[stem.casefold()] > 1), None)
    if clash is not None:  # the same id twice, or a hashed name that is also a plain id
        raise InputError(f"two formulas would both be written to {clash}.graphml; rename one")
    return stems


def _short_hash(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:8]


def render_dot(dot: str, out: str | Path) -> None:
    """Write DOT text to `out`: as is for .dot/.gv, drawn by Graphviz for .png/.svg/.pdf."""
    out = Path(out)
    fmt = out.suffix.lstrip(".").lower()
    if fmt in ("dot", "gv"):
        write_text_atomic(out, dot)
        return
    if fmt not in ("png", "svg", "pdf"):
        raise InputError(f"{out}: cannot draw to '.{fmt}'; use .png, .svg, .pdf or .dot")
    binary = shutil.which("dot")
    if binary is None:
        raise TleafError(
            "Graphviz 'dot' not found: apt-get install -y graphviz, or write a .dot file instead"
        )
    tmp = atomic_path(out)
    try:
        proc = subprocess.run(
            [binary, f"-T{fmt}", "-o", str(tmp)],
            input=dot,
            text=True,
            capture_output=True,
            timeout=60,
        )
        if proc.returncode != 0:
            raise TleafError(f"Graphviz failed: {proc.stderr.strip().splitlines()[-1:]}")
        tmp.replace(out)
    finally:
        tmp.unlink(missing_ok=True)


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _dot_id(text: str) -> str:
    return _quote(text)
