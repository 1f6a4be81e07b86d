"""Task graphs as knowledge (knowledge/task_graphs.py): every rule checked against a brute-force
reading of the graph on every order of up to 4 steps, and bad graphs refused by file and edge."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import pytest

from tleaf_cli.data.formula_files import read_formulas
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.task_graphs import graph_rules, read_task_graph, write_graph_knowledge
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies

# A small recipe as CaptainCook4D writes it: START -> rinse -> cook -> serve -> END, and
# START -> cut -> cook; cut and rinse in either order. Node ids are not in order on purpose.
TEA = {
    "steps": {
        "0": "START",
        "3": "Rinse-Rinse the rice",
        "1": "Cut-Cut the onion",
        "2": "Cook -Cook the rice",
        "4": "Serve-Serve on a plate",
        "5": "END",
    },
    "edges": [[0, 3], [0, 1], [3, 2], [1, 2], [2, 4], [4, 5]],
}


def write_json(tmp_path: Path, data: object, name: str = "rice.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data) if not isinstance(data, str) else data)
    return path


def words(atoms: list[str], max_len: int = 4):
    """Every sequence of 1..max_len steps over `atoms` (repeats allowed)."""
    for n in range(1, max_len + 1):
        yield from itertools.product(atoms, repeat=n)


def first(word: tuple[str, ...], atom: str) -> int | None:
    return word.index(atom) if atom in word else None


def test_rules_match_brute_force_on_every_order(tmp_path: Path) -> None:
    graph = read_task_graph(write_json(tmp_path, TEA))
    rules = graph_rules(graph, at_most_once=True, last_step_ends=True)
    names = {r.name for r in rules}
    assert names == {
        "rice.before.s3.s2",
        "rice.before.s1.s2",
        "rice.before.s2.s4",
        *(f"rice.once.s{n}" for n in (3, 1, 2, 4)),
        "rice.ends",
    }
    atom = graph.atoms
    other = "stir_the_pot"  # a step outside the graph: rules say nothing about it
    alphabet = [atom[n] for n in ("1", "2", "3", "4")] + [other]
    edges = [(atom[a], atom[b]) for a, b in (("3", "2"), ("1", "2"), ("2", "4"))]
    by_name = {r.name: parse(r.formula) for r in rules}
    for word in words(alphabet):
        trace = [{x} for x in word]
        for a, b in edges:
            fa, fb = first(word, a), first(word, b)
            want = fb is None or (fa is not None and fa < fb)  # no b before the first a
            name = next(r.name for r in rules if r.formula.startswith(f"(!{b} U {a})"))
            assert satisfies(trace, by_name[name]) == want, (name, word)
        for n in ("1", "2", "3", "4"):
            assert satisfies(trace, by_name[f"rice.once.s{n}"]) == (word.count(atom[n]) <= 1)
        assert satisfies(trace, by_name["rice.ends"]) == (word[-1] == atom["4"])


def test_edge_list_reads_like_the_json(tmp_path: Path) -> None:
    text = (
        "# rice\nSTART -> rinse\nrinse -> cook   # wash first\n\n"
        "cut, cook\ncook -> serve\nserve->end\n"
    )
    graph = read_task_graph(write_json(tmp_path, text, "rice.txt"))
    rules = graph_rules(graph, last_step_ends=True)
    assert [r.name for r in rules] == [
        "rice.before.rinse.cook",
        "rice.before.cut.cook",
        "rice.before.cook.serve",
        "rice.ends",
    ]
    assert rules[-1].formula == "F(last & (serve))"


def test_sinks_end_a_graph_without_end(tmp_path: Path) -> None:
    graph = read_task_graph(write_json(tmp_path, "a -> b\na -> c\n", "g.txt"))
    ends = graph_rules(graph, last_step_ends=True)[-1]
    assert ends.formula == "F(last & (b | c))"


def test_written_file_reads_back_as_formulas(tmp_path: Path) -> None:
    folder = tmp_path / "graphs"
    folder.mkdir()
    write_json(folder, TEA, "rice.json")
    write_json(folder, "x -> y\n", "toast.txt")
    out = tmp_path / "kb.ltl"
    done = write_graph_knowledge(folder, out, at_most_once=True)
    sources = read_formulas(out)
    assert [s.formula_id for s in sources] == [r.name for _, rules in done for r in rules]
    assert all(s.problem is None for s in sources)
    for s in sources:
        parse(s.text)
    text = out.read_text()
    assert "# atom rinse_rinse_the_rice = step s3 'Rinse-Rinse the rice'" in text


def test_steps_with_the_same_text_give_no_rule(tmp_path: Path) -> None:
    # heat, stir, heat again, serve: "stir before the second heating" would read as "stir before
    # the first", which every correct order breaks, so no edge touching a heating gives a rule
    data = {
        "steps": {"1": "Heat-Heat it", "2": "Stir-Stir", "3": "Heat -Heat it", "4": "Serve-Serve"},
        "edges": [[1, 2], [2, 3], [2, 4]],
    }
    graph = read_task_graph(write_json(tmp_path, data))
    rules = graph_rules(graph, at_most_once=True)
    assert [r.name for r in rules] == ["rice.before.s2.s4", "rice.once.s2", "rice.once.s4"]
    correct = [{graph.atoms[n]} for n in ("1", "2", "3", "4")]
    assert all(satisfies(correct, parse(r.formula)) for r in rules)


@pytest.mark.parametrize(
    ("content", "name", "message"),
    [
        (
            {"steps": {"0": "START", "1": "A-a"}, "edges": [[0, 1], [1, 9]]},
            "g.json",
            "edge 1 [1, 9]: unknown step 9",
        ),
        (
            {"steps": {"1": "A-a", "2": "B-b"}, "edges": [[1, 2], [2, 1]]},
            "g.json",
            "a cycle: 1 -> 2 -> 1",
        ),
        ('{"steps": {', "g.json", "not JSON (line 1"),
        (
            {"steps": {"1": "A-a"}, "edges": [[1]]},
            "g.json",
            "edge 0 ([1]) is not a [before, after] pair",
        ),
        ("a -> b\nnonsense\n", "g.txt", "line 2: expected 'a -> b' or 'a,b'"),
        ("a -> b\nb -> c\nc -> a\n", "g.txt", "a cycle: a -> b -> c -> a"),
    ],
)
def test_bad_graphs_name_file_and_edge(tmp_path: Path, content, name: str, message: str) -> None:
    path = write_json(tmp_path, content, name)
    with pytest.raises(InputError) as e:
        read_task_graph(path)
    assert str(e.value).startswith(str(path)) and message in str(e.value)


def test_cli_writes_compilable_rules_and_refuses_a_cycle(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    runner = CliRunner()
    graph = write_json(tmp_path, TEA)
    out = tmp_path / "kb.ltl"
    result = runner.invoke(app, ["task-graph", str(graph), "-o", str(out), "--at-most-once"])
    assert result.exit_code == 0, result.output
    assert "7 rules from 1 graphs" in result.output
    dfas = tmp_path / "dfas.parquet"
    result = runner.invoke(app, ["compile-dfa", str(out), "--one-hot", "-o", str(dfas)])
    assert result.exit_code == 0 and "7 of 7 formulas compiled" in result.output, result.output
    bad = write_json(tmp_path, "a -> b\nb -> a\n", "bad.txt")
    result = runner.invoke(app, ["task-graph", str(bad), "-o", str(tmp_path / "bad.ltl")])
    assert result.exit_code == 2 and "a cycle: a -> b -> a" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "bad.ltl").exists()


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("a -> b -> c", "line 2: one edge a line"),
        ("a,b,c", "line 2: one edge a line"),
    ],
)
def test_a_chain_on_one_line_is_refused_naming_the_line(
    tmp_path: Path, line: str, message: str
) -> None:
    path = write_json(tmp_path, f"x -> a\n{line}\n", "g.txt")
    with pytest.raises(InputError, match=message):
        read_task_graph(path)


def test_an_arrow_edge_may_name_steps_with_commas(tmp_path: Path) -> None:
    graph = read_task_graph(write_json(tmp_path, "Cut, then rinse -> cook\n", "g.txt"))
    assert graph.edges == [("Cut, then rinse", "cook")]


@pytest.mark.parametrize(
    ("content", "name"),
    [({"steps": {"1": "A-a"}, "edges": []}, "g.json"), ("# nothing\n", "g.txt")],
)
def test_a_graph_without_edges_exits_2_the_same_way(tmp_path: Path, content, name: str) -> None:
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    path = write_json(tmp_path, content, name)
    out = tmp_path / "kb.ltl"
    result = CliRunner().invoke(app, ["task-graph", str(path), "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert f"{path}: no edges (one 'a -> b' or 'a,b' a line" in result.output.replace("\n", "")
    assert not out.exists()


def test_graph_rules_of_something_not_a_graph_is_a_tleaf_error() -> None:
    from tleaf_cli.errors import TleafError

    with pytest.raises(TleafError, match="graph"):
        graph_rules("x")  # type: ignore[arg-type]


def test_a_graph_that_gives_no_rule_is_refused(tmp_path: Path) -> None:
    path = write_json(tmp_path, "START -> a\na -> END\n", "g.txt")
    with pytest.raises(InputError, match="no rule: every edge is from START or into END"):
        write_graph_knowledge(path, tmp_path / "kb.ltl")
    assert not (tmp_path / "kb.ltl").exists()
    write_graph_knowledge(path, tmp_path / "kb.ltl", at_most_once=True)
