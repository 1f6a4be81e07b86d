"""Precedence graphs (a recipe's task graph, a flowchart) as knowledge: one LTLf rule per edge.

A graph says which step must come before which. Two inputs are read:

- CaptainCook4D's task graphs: JSON `{"steps": {id: "Verb-text"}, "edges": [[a, b], ...]}`, an
  edge a -> b meaning a comes before b, with a node "START" and a node "END";
- a plain edge list: a text file, one edge a line, `a -> b` or `a,b`, `#` comments, blank lines
  ignored; the names are the steps (a node START or END, any case, is read as those nodes). A
  line with `->` is split there only, so a step's name may hold a comma; a chain `a -> b -> c`
  (or `a,b,c`) on one line is refused, naming the line, rather than read as one step "b -> c".

A step's atom is `step_atom(text)` (data/captaincook.py): the same words, lower case, joined by _,
so a recording's steps read by `read-recordings` name the same atoms. Two nodes with the same
text (CaptainCook4D repeats a few, e.g. "Microwave for 1.5 minutes" in dressedupmeatballs) share
their atom, and a recording cannot tell them apart: an edge that touches such a node would speak
of "the second microwaving" while the rule sees the first, so it gives no rule, nor does such a
step get an at-most-once rule (the file's header counts them).

**The rules** (names `<recipe>.<kind>.<steps>`, the recipe being the file's stem, the steps
`s<id>` for JSON nodes and the atoms for an edge list):

- `<recipe>.before.<a>.<b>`: `(!b U a) | G !b` for an edge a -> b: b does not occur before
  the first a, and b does not occur without a (Declare's precedence). A recording that does b
  after skipping a breaks it; one that skips b keeps it.
- with `at_most_once`, `<recipe>.once.<a>`: `G(a -> WX G !a)` for every step: a occurs at most
  once.
- with `last_step_ends`, `<recipe>.ends`: `F(last & (p1 | p2 | ...))`: the recording's last step
  is one of END's predecessors (the graph's sinks when it has no END).

Edges from START are skipped (every step may come first); edges into END only feed `ends`. An
edge that names an unknown node, a cycle, a graph without edges (JSON or edge list alike), a
graph source that gives no rule at all, or a file that does not read stops with InputError
naming the file and the edge or line.
"""

from __future__ import annotations

import os
import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tleaf_cli.data.activity_names import activity_atoms
from tleaf_cli.data.artifacts import read_json_file, read_text_file, write_text_atomic
from tleaf_cli.data.captaincook import step_atom
from tleaf_cli.errors import ArgumentTypeError, InputError
from tleaf_cli.knowledge.declare import Constraint

START, END = "START", "END"
GRAPH_SUFFIXES = (".json", ".txt")
ARROW = "->"
NO_EDGES = "no edges (one 'a -> b' or 'a,b' a line; in JSON, [before, after] pairs in 'edges')"


@dataclass(frozen=True)
class TaskGraph:
    """A precedence graph: its steps (node -> text), edges (node, node), and the step atoms."""

    recipe: str
    path: str
    steps: dict[str, str]  # node id -> text, START and END included when present
    edges: list[tuple[str, str]]
    atoms: dict[str, str]  # node id -> atom, for the steps (not START/END)
    label: dict[str, str]  # node id -> its part of a rule name

    def step_nodes(self) -> list[str]:
        return [n for n, text in self.steps.items() if text not in (START, END)]


@dataclass(frozen=True)
class GraphRule:
    """One rule of a graph: name, formula, and the comment that says where it comes from."""

    name: str
    formula: str
    comment: str


def recipe_name(path: str | os.PathLike) -> str:
    """The recipe a graph file is named for: its stem, with characters a rule name cannot hold
    (and dots, which separate the name's parts) as _."""
    return re.sub(r"[^A-Za-z0-9_-]", "_", Path(path).stem) or "graph"


def read_task_graph(path: str | os.PathLike) -> TaskGraph:
    """A graph from CaptainCook4D's JSON (`.json`) or a plain edge list (any other suffix)."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        graph = _from_json(path, read_json_file(path))
    else:
        graph = _from_edges(path, read_text_file(path))
    _check_acyclic(graph)
    return graph


def _from_json(path: Path, data: Any) -> TaskGraph:
    if not isinstance(data, dict) or not isinstance(data.get("steps"), dict):
        raise InputError(f"{path}: expected an object with 'steps' {{id: text}} and 'edges'")
    edges_in = data.get("edges")
    if not isinstance(edges_in, list):
        raise InputError(f"{path}: 'edges' must be a list of [before, after] pairs")
    steps = {str(k).strip(): str(v).strip() for k, v in data["steps"].items()}
    edges = []
    for k, edge in enumerate(edges_in):
        if not (isinstance(edge, list) and len(edge) == 2):
            raise InputError(f"{path}: edge {k} ({edge!r}) is not a [before, after] pair")
        a, b = (str(x).strip() for x in edge)
        for node in (a, b):
            if node not in steps:
                raise InputError(f"{path}: edge {k} [{a}, {b}]: unknown step {node}")
        edges.append((a, b))
    if not edges:
        raise InputError(f"{path}: {NO_EDGES}")
    atoms = {n: step_atom(t) for n, t in steps.items() if t not in (START, END)}
    label = {n: f"s{n}" if re.fullmatch(r"[A-Za-z0-9_-]+", n) else atoms.get(n, "x") for n in steps}
    return TaskGraph(recipe_name(path), str(path), steps, edges, atoms, label)


def _from_edges(path: Path, text: str) -> TaskGraph:
    edges = []
    names: dict[str, None] = {}
    for number, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        a, b = (_special(x) for x in _edge(path, number, line))
        edges.append((a, b))
        names.update({a: None, b: None})
    if not edges:
        raise InputError(f"{path}: {NO_EDGES}")
    atoms = activity_atoms(n for n in names if n not in (START, END))
    steps = {n: n for n in names}
    label = {n: atoms.get(n, n.lower()) for n in names}
    return TaskGraph(recipe_name(path), str(path), steps, edges, atoms, label)


def _edge(path: Path, number: int, line: str) -> tuple[str, str]:
    """The two steps of an edge list's line: split at `->` if it has one, else at `,`."""
    parts = [p.strip() for p in line.split(ARROW if ARROW in line else ",")]
    if len(parts) > 2 and all(parts):
        raise InputError(
            f"{path}: line {number}: one edge a line, got a chain of {len(parts)} steps "
            f"{line!r} (write a -> b and b -> c on lines of their own)"
        )
    if len(parts) != 2 or not all(parts):
        raise InputError(f"{path}: line {number}: expected 'a -> b' or 'a,b', got {line!r}")
    return parts[0], parts[1]


def _special(name: str) -> str:
    return name.upper() if name.upper() in (START, END) else name


def _check_acyclic(graph: TaskGraph) -> None:
    successors: dict[str, list[str]] = {n: [] for n in graph.steps}
    for a, b in graph.edges:
        successors[a].append(b)
    state: dict[str, int] = {}  # 1: on the path, 2: done
    for root in graph.steps:
        if root in state:
            continue
        path, stack = [root], [iter(successors[root])]
        state[root] = 1
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                stack.pop()
            elif state.get(nxt) == 1:
                cycle = [*path[path.index(nxt) :], nxt]
                raise InputError(f"{graph.path}: a cycle: {' -> '.join(cycle)}")
            elif nxt not in state:
                state[nxt] = 1
                path.append(nxt)
                stack.append(iter(successors[nxt]))


def graph_rules(
    graph: TaskGraph, at_most_once: bool = False, last_step_ends: bool = False
) -> list[GraphRule]:
    """The graph's rules (see the module docstring), `before` rules in edge order, then `once`
    in node order, then `ends`. An edge or step whose atom names two nodes (`shared_atoms`) gives
    no rule, nor does an edge that repeats another edge's atoms."""
    if not isinstance(graph, TaskGraph):
        raise ArgumentTypeError(
            "graph", f"expected a TaskGraph (read_task_graph), not {type(graph).__name__}"
        )
    r, text, atom = graph.recipe, graph.steps, graph.atoms
    shared = shared_atoms(graph)
    rules: list[GraphRule] = []
    seen: set[tuple[str, str]] = set()
    for a, b in graph.edges:
        if START in (text[a], text[b]) or text[b] == END or text[a] == END:
            continue
        pair = (atom[a], atom[b])
        if shared & set(pair) or pair in seen:
            continue
        seen.add(pair)
        rules.append(
            GraphRule(
                f"{r}.before.{graph.label[a]}.{graph.label[b]}",
                Constraint("precedence", pair).formula,  # Declare's precedence
                f"{text[a]!r} before {text[b]!r}",
            )
        )
    if at_most_once:
        done: set[str] = set()
        for n in graph.step_nodes():
            if atom[n] not in done and atom[n] not in shared:
                done.add(atom[n])
                rules.append(
                    GraphRule(
                        f"{r}.once.{graph.label[n]}",
                        f"G({atom[n]} -> WX G !{atom[n]})",
                        f"{text[n]!r} at most once",
                    )
                )
    if last_step_ends:
        ends = _last_steps(graph)
        if ends:
            rules.append(
                GraphRule(
                    f"{r}.ends",
                    f"F(last & ({' | '.join(ends)}))",
                    "the last step is one of: " + ", ".join(ends),
                )
            )
    return rules


def shared_atoms(graph: TaskGraph) -> set[str]:
    """The atoms that name two or more steps of the graph (steps with the same text)."""
    counts = Counter(graph.atoms[n] for n in graph.step_nodes())
    return {a for a, n in counts.items() if n > 1}


def _last_steps(graph: TaskGraph) -> list[str]:
    """The atoms a recording may end with: END's predecessors, or the sinks without END."""
    text = graph.steps
    ends = [n for n, t in text.items() if t == END]
    if ends:
        nodes = [a for a, b in graph.edges if b in ends and text[a] not in (START, END)]
    else:
        has_successor = {a for a, b in graph.edges if text[b] not in (START, END)}
        nodes = [n for n in graph.step_nodes() if n not in has_successor]
    return list(dict.fromkeys(graph.atoms[n] for n in nodes))


def graph_files(source: str | os.PathLike) -> list[Path]:
    """`source` itself, or a folder's graph files (.json, .txt) in name order."""
    source = Path(source)
    if not source.is_dir():
        return [source]
    files = sorted(p for p in source.iterdir() if p.suffix.lower() in GRAPH_SUFFIXES)
    if not files:
        raise InputError(f"{source}: no task graphs (.json or .txt files) in the folder")
    return files


def write_graph_knowledge(
    source: str | os.PathLike,
    out: str | os.PathLike,
    at_most_once: bool = False,
    last_step_ends: bool = False,
) -> list[tuple[TaskGraph, list[GraphRule]]]:
    """Read the graph `source` (or every graph of a folder) and write one `.ltl` at `out` with
    every graph's rules, each recipe's under a header naming its file and step -> atom map."""
    graphs = [read_task_graph(p) for p in graph_files(source)]
    recipes = [g.recipe for g in graphs]
    if len(set(recipes)) != len(recipes):
        raise InputError(f"{source}: two graph files name the same recipe ({sorted(recipes)})")
    done = [(g, graph_rules(g, at_most_once, last_step_ends)) for g in graphs]
    if not any(rules for _, rules in done):
        raise InputError(f"{source}: no rule: every edge is from START or into END")
    chosen = [
        o for o, on in (("at-most-once", at_most_once), ("last-step-ends", last_step_ends)) if on
    ]
    lines = [
        f"# precedence rules written by tleaf task-graph from {Path(source).name}: an edge a -> b "
        "as (!b U a) | G !b (b not before the first a, nor without a)",
        f"# options: {', '.join(chosen) or 'none'}",
    ]
    for graph, rules in done:
        shared = shared_atoms(graph)
        note = f"; no rule on {len(shared)} atoms that name two steps" if shared else ""
        lines += ["", f"# recipe {graph.recipe}: {Path(graph.path).name}, {len(rules)} rules{note}"]
        lines += [
            f"# atom {graph.atoms[n]} = step {graph.label[n]} {graph.steps[n]!r}"
            for n in graph.step_nodes()
        ]
        for rule in rules:
            lines += [f"# {rule.comment}", f"{rule.name}: {rule.formula}"]
    write_text_atomic(out, "\n".join(lines) + "\n")
    return done
