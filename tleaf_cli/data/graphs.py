"""DFAs as graph files for graph tools: networkx graphs, GraphML, and Graphviz DOT."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
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
    written = 0
    for row in rows:
        if row["error"] is not None:
            continue
        stem = _UNSAFE.sub("_", row["formula_id"])
        tmp = atomic_path(directory / f"{stem}.graphml")
        try:
            nx.write_graphml(row_to_networkx(row), tmp)
            tmp.replace(directory / f"{stem}.graphml")
        finally:
            tmp.unlink(missing_ok=True)
        write_text_atomic(directory / f"{stem}.dot", row_to_dot(row))
        written += 1
    return written


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
