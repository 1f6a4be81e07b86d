"""Knowledge bases: the file format, per-video extraction, mining, and `tleaf kb-extract`."""

from __future__ import annotations

import random
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.artifacts import read_provenance
from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.errors import ArgumentError, InputError
from tleaf_cli.knowledge.base import (
    KnowledgeBase,
    Rule,
    affordance_rule,
    mine_knowledge_base,
    ordering_rule,
    read_knowledge_base,
    rule_set_id,
    rules_for,
    sample_formula,
    write_knowledge_base,
)
from tleaf_cli.logic import mona
from tleaf_cli.logic.checker import check
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies
from tleaf_cli.tasks.action_recognition.activities import read_activities

runner = CliRunner()
EXAMPLE = Path(__file__).parent.parent / "examples" / "kitchen.kb.ltl"
KB_TEXT = """\
# kitchen rules
affordance.cut_milk: G !cut_milk
ordering.rinse_cabbage.cook_cabbage: (!cook_cabbage U rinse_cabbage) | G !cook_cabbage
ordering.cut_onion.fry_onion: (!fry_onion U cut_onion) | G !fry_onion
"""


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture
def kb(tmp_path: Path) -> KnowledgeBase:
    path = tmp_path / "kb.ltl"
    path.write_text(KB_TEXT, encoding="utf-8")
    return read_knowledge_base(path)


def test_reads_kinds_formulas_and_atoms(kb: KnowledgeBase) -> None:
    assert [r.kind for r in kb] == ["affordance", "ordering", "ordering"]
    assert kb.rules[1] == ordering_rule("cabbage", "rinse", "cook")
    assert kb.rules[0] == affordance_rule("cut", "milk")
    assert kb.rules[2].atoms == ("cut_onion", "fry_onion")


def test_the_example_knowledge_base_reads(kb: KnowledgeBase) -> None:
    example = read_knowledge_base(EXAMPLE)
    assert len(example.of_kind("affordance")) == 3 and len(example.of_kind("ordering")) == 3
    assert set(kb.rules) <= set(example.rules)


def test_extraction_picks_exactly_the_rules_whose_atoms_all_occur(kb: KnowledgeBase) -> None:
    present = ["rinse_cabbage", "cut_onion", "cook_cabbage", "stir_soup"]  # fry_onion absent
    assert [r.name for r in rules_for(kb, present)] == ["ordering.rinse_cabbage.cook_cabbage"]
    assert [r.name for r in rules_for(kb, [*present, "fry_onion", "cut_milk"])] == [
        r.name for r in kb
    ]
    assert rules_for(kb, ["cook_cabbage"]) == []


def test_extraction_agrees_with_its_definition_on_random_sets() -> None:
    rng = random.Random(3)
    names = [f"a{k}_x" for k in range(8)]
    rules = [
        Rule(
            f"ordering.r{k}",
            "ordering",
            "true",
            tuple(sorted(rng.sample(names, rng.randint(0, 3)))),
        )
        for k in range(30)
    ]
    kb = KnowledgeBase(tuple(rules))
    for _ in range(200):
        present = set(rng.sample(names, rng.randint(0, 8)))
        expected = [r for r in rules if set(r.atoms) <= present]
        assert rules_for(kb, present) == expected


def test_sample_formula_is_the_conjunction(kb: KnowledgeBase) -> None:
    assert sample_formula([]) == "true"
    formula = parse(sample_formula(kb.rules))
    parts = [parse(r.formula) for r in kb]
    rng = random.Random(0)
    atoms = ["cut_milk", "rinse_cabbage", "cook_cabbage", "cut_onion", "fry_onion", "other_x"]
    for _ in range(300):
        trace = [{rng.choice(atoms)} for _ in range(rng.randint(1, 6))]
        assert satisfies(trace, formula) == all(satisfies(trace, p) for p in parts)


def test_rule_set_id_is_stable_and_order_free(kb: KnowledgeBase) -> None:
    a, b, c = kb.rules
    assert rule_set_id([a, b]) == rule_set_id([b, a])
    assert len({rule_set_id(s) for s in ([], [a], [b], [a, b], [a, b, c])}) == 5
    assert rule_set_id([a]).startswith("rs-") and len(rule_set_id([a])) == 15


def test_write_then_read_round_trips(kb: KnowledgeBase, tmp_path: Path) -> None:
    write_knowledge_base(kb, tmp_path / "again.ltl", ["a header"])
    assert read_knowledge_base(tmp_path / "again.ltl") == kb
    assert (tmp_path / "again.ltl").read_text().startswith("# a header\n")


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("G !cut_milk", "line 2: rule 'L2' needs a name 'affordance.<rest>' or 'ordering.<rest>'"),
        ("rule.x: G !a", "line 2: rule 'rule.x' needs a name"),
        ("affordance: G !a", "line 2: rule 'affordance' needs a name"),
        ("affordance.x: G !(a", "line 2, column 20: formula ends too early"),
        ("affordance.cut_milk: G !a", "line 2: name 'affordance.cut_milk' already used on line 1"),
    ],
)
def test_bad_knowledge_base_lines_are_located(tmp_path: Path, line: str, expected: str) -> None:
    path = tmp_path / "kb.ltl"
    path.write_text(f"affordance.cut_milk: G !cut_milk\n{line}\n", encoding="utf-8")
    with pytest.raises(InputError) as e:
        read_knowledge_base(path)
    assert str(e.value).startswith(f"{path}: ") and expected in str(e.value)


# Mining.

VOCAB = (["wash", "cut", "fry", "pour"], ["onion", "milk", "rice"])


def test_mining_finds_planted_rules_and_respects_min_support() -> None:
    onion = [("wash", "onion"), ("cut", "onion"), ("fry", "onion")]
    sequences = [
        onion,
        [("pour", "milk"), *onion],
        [("wash", "onion"), ("pour", "milk"), ("cut", "onion")],
        [("wash", "rice"), ("fry", "rice"), ("wash", "rice")],  # repeats: first occurrences count
        [("fry", "rice"), ("wash", "rice")],  # breaks wash-before-fry on rice
    ]
    kb = mine_knowledge_base(sequences, VOCAB, min_support=2)
    names = {r.name for r in kb}
    orderings = {r.name for r in kb.of_kind("ordering")}
    assert orderings == {
        "ordering.wash_onion.cut_onion",  # support 3
        "ordering.wash_onion.fry_onion",  # support 2
        "ordering.cut_onion.fry_onion",  # support 2
    }
    assert kb.of_kind("ordering")[0] == ordering_rule("onion", "wash", "cut")
    # pour was seen, on milk only; every seen action and ingredient pair never seen is forbidden.
    assert {"affordance.pour_onion", "affordance.cut_milk", "affordance.pour_rice"} <= names
    assert "affordance.wash_onion" not in names and "affordance.fry_rice" not in names
    strict = mine_knowledge_base(sequences, VOCAB, min_support=3)
    assert {r.name for r in strict.of_kind("ordering")} == {"ordering.wash_onion.cut_onion"}


def test_mining_ignores_unseen_actions_and_ingredients() -> None:
    kb = mine_knowledge_base([[("cut", "onion")]], (["cut", "fry"], ["onion", "milk"]), 1)
    assert [r.name for r in kb] == []  # fry and milk never seen: no evidence about them


@pytest.mark.parametrize(
    ("sequences", "vocabulary", "min_support", "argument", "expected"),
    [
        ([["cut_onion"]], VOCAB, 1, r"sequences\[0\]\[0\]", "pair, not the string 'cut_onion'"),
        ([[("cut", "onion", "x")]], VOCAB, 1, r"sequences\[0\]\[0\]", "pair"),
        ("cut", VOCAB, 1, "sequences", "the string 'cut'"),
        ([[("cut", "onion")]], VOCAB, float("nan"), "min_support", "int .*nan"),
        ([[("cut", "onion")]], VOCAB, 0, "min_support", "at least 1, not 0"),
        ([[("cut", "onion")]], ("cut", "onion"), 1, "vocabulary", "the string 'cut'"),
        ([[("cut", "onion")]], (["cut"],), 1, "vocabulary", r"\(actions, ingredients\)"),
    ],
)
def test_mining_refuses_wrong_arguments_by_name(
    sequences, vocabulary, min_support, argument, expected
) -> None:
    """Atom strings instead of (action, ingredient) pairs, a NaN support (which no count
    reaches: no ordering mined, silently) or a vocabulary of letters: an ArgumentError naming
    the argument."""
    with pytest.raises(ArgumentError, match=rf"^{argument}: .*{expected}"):
        mine_knowledge_base(sequences, vocabulary, min_support)


def test_mining_recovers_the_generating_knowledge_base(tmp_path: Path) -> None:
    data_path, kb_path = tmp_path / "a.parquet", tmp_path / "kb.ltl"
    args = ["--actions", 8, "--ingredients", 6, "--feature-dim", 4, "--train", 120, "--seed", 2]
    assert tleaf("gen-activities", "-o", data_path, "--kb-out", kb_path, *args).exit_code == 0
    data, planted = read_activities(data_path), read_knowledge_base(kb_path)
    train = [data.pairs(v) for v in data.split("train")]
    mined = mine_knowledge_base(train, (data.actions, data.ingredients), min_support=3)
    # Sound: nothing mined is broken by a training video.
    for steps in train:
        atoms = [f"{a}_{i}" for a, i in steps]
        assert satisfies([{a} for a in atoms], parse(sample_formula(rules_for(mined, atoms))))
    # Complete for what the data shows: planted orderings seen >= 3 times, planted affordances
    # over actions and ingredients that occur.
    mined_names = {r.name for r in mined}
    support = {
        r.name: sum(set(r.atoms) <= {f"{a}_{i}" for a, i in s} for s in train)
        for r in planted.of_kind("ordering")
    }
    assert any(n >= 3 for n in support.values())
    assert {n for n, k in support.items() if k >= 3} <= mined_names
    assert {r.name for r in planted.of_kind("affordance")} <= mined_names


# kb-extract.


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("kbx")
    paths = {"data": d / "act.parquet", "kb": d / "kb.ltl"}
    args = ["--actions", 6, "--ingredients", 5, "--feature-dim", 4]
    args += ["--train", 12, "--val", 4, "--test", 4, "--min-steps", 2, "--max-steps", 6]
    result = tleaf("gen-activities", "-o", paths["data"], "--kb-out", paths["kb"], *args)
    assert result.exit_code == 0, result.output
    return paths


def _count_mona(monkeypatch) -> list[int]:
    calls = [0]
    real = mona.run_mona

    def counting(*args, **kwargs):
        calls[0] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(mona, "run_mona", counting)
    return calls


def test_kb_extract_writes_samples_and_one_dfa_per_rule_set(tiny, tmp_path, monkeypatch) -> None:
    calls = _count_mona(monkeypatch)
    out = tmp_path / "out"
    mona_only = ["--engine", "mona"]  # the cache holds MONA's results; progression is not cached
    result = tleaf("kb-extract", tiny["kb"], tiny["data"], "-o", out, "--no-cache", *mona_only)
    assert result.exit_code == 0, result.output
    samples = pq.read_table(out / "samples.parquet").to_pylist()
    dfas = read_dfas(out / "dfas.parquet")
    data, kb = read_activities(tiny["data"]), read_knowledge_base(tiny["kb"])
    assert read_provenance(out / "samples.parquet").kind == "kb-samples"
    assert [s["video_id"] for s in samples] == [v.video_id for v in data.videos]
    ids = dfas.ids()
    assert len(ids) == len(set(ids)) == len({s["formula_id"] for s in samples})
    assert calls[0] == len(ids) < len(samples)  # each distinct rule set compiled exactly once
    for s, video in zip(samples, data.videos, strict=True):
        rules = rules_for(kb, data.atoms(video))
        assert s["formula_id"] == rule_set_id(rules) and s["num_rules"] == len(rules)
        assert s["split"] == video.split and s["rules"] == sorted(r.name for r in rules)
        row = dfas.row(s["formula_id"])
        assert row["alphabet"] == "one-hot" and row["formula"] == sample_formula(rules)
        assert row["atoms"] == sorted({a for r in rules for a in r.atoms})
        assert check(dfas.dfa(s["formula_id"]), [[{a} for a in data.atoms(video)]])[0]

    # Again with the cache: no MONA call at all, the same tables.
    calls[0] = 0
    again = tmp_path / "again"
    assert tleaf("kb-extract", tiny["kb"], tiny["data"], "-o", again, *mona_only).exit_code == 0
    assert tleaf("kb-extract", tiny["kb"], tiny["data"], "-o", again, *mona_only).exit_code == 0
    assert calls[0] == len(ids)  # the first of the two cached runs filled the cache
    assert pq.read_table(again / "dfas.parquet").equals(pq.read_table(out / "dfas.parquet"))

    # The default engine builds the same minimal DFAs in process, without MONA: its route is
    # decided by counted work (logic/compile.py, AUTO_WORK), the same under any load.
    calls[0] = 0
    auto = tmp_path / "auto"
    assert tleaf("kb-extract", tiny["kb"], tiny["data"], "-o", auto, "--no-cache").exit_code == 0
    assert calls[0] == 0
    by_progression = read_dfas(auto / "dfas.parquet")
    assert by_progression.ids() == ids
    assert all(by_progression.dfa(i) == dfas.dfa(i) for i in ids)


def test_kb_extract_mines_from_the_train_split(tiny, tmp_path) -> None:
    out = tmp_path / "out"
    result = tleaf("kb-extract", tiny["data"], "-o", out, "--mine", "--min-support", 2)
    assert result.exit_code == 0, result.output
    assert "rules mined" in result.output
    mined = read_knowledge_base(out / "kb.ltl")
    data = read_activities(tiny["data"])
    expected = mine_knowledge_base(
        [data.pairs(v) for v in data.split("train")], (data.actions, data.ingredients), 2
    )
    assert mined == expected and len(mined) > 0
    samples = pq.read_table(out / "samples.parquet").to_pylist()
    assert {s["formula_id"] for s in samples} == set(read_dfas(out / "dfas.parquet").ids())


def test_a_rule_set_that_fails_to_compile_exits_1(tiny, tmp_path, monkeypatch) -> None:
    def timeout(*args, **kwargs):
        raise mona.MonaTimeout("MONA did not finish within 30 s")

    monkeypatch.setattr(mona, "run_mona", timeout)
    out = tmp_path / "out"
    result = tleaf(
        "kb-extract", tiny["kb"], tiny["data"], "-o", out, "--no-cache", "--engine", "mona"
    )
    assert result.exit_code == 1
    assert "rule set rs-" in result.output and "did not finish" in result.output
    rows = read_dfas(out / "dfas.parquet").rows
    assert rows and all(r["error"].startswith("rule set rs-") for r in rows)


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["{data}"], "give a knowledge base file, or --mine"),
        (["{kb}", "{data}", "{data}"], "one or two files"),
        (["{kb}", "{missing}"], "no such file"),
        (["{data}", "{data}"], "expected columns formula_id and formula"),
        (["{kb}", "{kb}"], "not a readable Parquet file"),
        (["{kb}", "{data}", "--formula-from", "predictions"], "'predictions' is not one of"),
    ],
)
def test_kb_extract_bad_calls_exit_2(tiny, tmp_path, args, expected) -> None:
    paths = {**{k: str(v) for k, v in tiny.items()}, "missing": str(tmp_path / "none.parquet")}
    out = tmp_path / "out"
    result = tleaf("kb-extract", *[a.format(**paths) for a in args], "-o", out)
    assert result.exit_code == 2, result.output
    assert expected in result.output and "Traceback" not in result.output
    assert not (out / "samples.parquet").exists()


def test_kb_extract_never_reads_unlabelled_videos(tmp_path) -> None:
    data, kb = tmp_path / "act.parquet", tmp_path / "kb.ltl"
    args = ["--actions", 6, "--ingredients", 5, "--feature-dim", 4, "--train", 6, "--val", 2]
    args += ["--test", 2, "--unlabelled", 5, "--min-steps", 2, "--max-steps", 6]
    assert tleaf("gen-activities", "-o", data, "--kb-out", kb, *args).exit_code == 0
    result = tleaf("kb-extract", kb, data, "-o", tmp_path / "out")
    assert result.exit_code == 0, result.output
    samples = pq.read_table(tmp_path / "out" / "samples.parquet").to_pylist()
    labelled = [v.video_id for v in read_activities(data).videos if v.split != "unlabelled"]
    assert [s["video_id"] for s in samples] == labelled and len(labelled) == 10


def test_kb_extract_per_ingredient_splits_each_videos_rule_set(tiny, tmp_path) -> None:
    out = tmp_path / "out"
    result = tleaf("kb-extract", tiny["kb"], tiny["data"], "-o", out, "--rule-sets", "ingredient")
    assert result.exit_code == 0, result.output
    rows = pq.read_table(out / "samples.parquet").to_pylist()
    data, kb = read_activities(tiny["data"]), read_knowledge_base(tiny["kb"])
    dfas = read_dfas(out / "dfas.parquet")
    for video in data.videos:
        mine = [r for r in rows if r["video_id"] == video.video_id]
        assert all(len(r["ingredients"]) == 1 for r in mine)  # this KB: one ingredient per rule
        assert len({r["ingredients"][0] for r in mine}) == len(mine)
        whole = sorted(r.name for r in rules_for(kb, data.atoms(video)))
        assert sorted(n for r in mine for n in r["rules"]) == whole
        for r in mine:
            assert {a.split("_", 1)[1] for a in dfas.row(r["formula_id"])["atoms"]} == set(
                r["ingredients"]
            )


def test_the_guarded_knowledge_base_is_the_checkers_verdict_on_any_sequence(
    kb: KnowledgeBase,
) -> None:
    """A sequence meets every rule set of `KnowledgeRuleSets.whole` exactly when it meets the
    rules `rules_for` picks from its own atoms: one formula set, the same for every sequence,
    says what the checker says."""
    import numpy as np

    from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
    from tleaf_cli.losses import violates

    vocabulary = sorted({a for r in kb for a in r.atoms} | {"stir_milk", "cut_cabbage"})
    rules = KnowledgeRuleSets(kb, vocabulary)
    whole = rules.whole()
    assert len(whole) == 3  # one per ingredient: milk, cabbage, onion
    rng = random.Random(0)
    verdicts = []
    for _ in range(300):
        seq = np.array([rng.randrange(len(vocabulary)) for _ in range(rng.randint(1, 6))])
        present = {vocabulary[i] for i in seq}
        picked = rules.one_each([present])[0]
        checker = picked is None or not violates([picked], [seq])[0]
        meets_whole = not violates(whole, [seq] * len(whole)).any()
        assert meets_whole == checker, [vocabulary[i] for i in seq]
        verdicts.append(checker)
    assert 0 < sum(verdicts) < len(verdicts)  # both verdicts were tried


def test_a_guard_leaves_a_rule_that_forbids_its_atom_as_it_is(kb: KnowledgeBase) -> None:
    from tleaf_cli.knowledge.base import guarded

    never, order = kb.of_kind("affordance")[0], kb.of_kind("ordering")[0]
    assert guarded(never).formula == never.formula
    first, then = order.atoms
    assert guarded(order).formula == f"(F {first} & F {then}) -> ({order.formula})"
    assert guarded(order).name != order.name  # its own rule-set ids


def _group_count(atom_sets: list[tuple[str, ...]]) -> int:
    """How many groups `rule_set._conjunction` makes: formulas joined by shared atoms, plus one
    for the atomless formulas."""
    parts = [set(atoms) for atoms in atom_sets if atoms]
    for i in reversed(range(len(parts))):  # merge each into the first earlier one it meets
        j = next((j for j in range(i) if parts[j] & parts[i]), None)
        if j is not None:
            parts[j] |= parts.pop(i)
    return len(parts) + (len(parts) < len(atom_sets) and not all(atom_sets))


def test_a_rule_sets_dfa_is_the_pairwise_product_of_its_rules() -> None:
    """`RuleSet` conjoins its groups of rules (connected by shared atoms) in one walk
    (`conjunction.conjoin_nonempty`): the same DFA as pairwise `DFA.product`s of every rule, then
    `minimize_nonempty`, on random rule sets whose rules share atoms or not, use X, WX, U, ...
    (letter 0 then moves a group), or name no atom ("last", "X true")."""
    import functools

    from tleaf_cli.data.random_formulas import random_formula
    from tleaf_cli.logic.compile import compile_formula
    from tleaf_cli.logic.dfa import DFA
    from tleaf_cli.rule_set import RuleSet

    vocabulary = [f"p{i}" for i in range(12)]
    atomless = ["last", "!last", "X true", "X X true", "WX false", "true"]
    rng = random.Random(3)
    several = unsatisfiable = 0
    for case in range(120):
        formulas = []
        for _ in range(rng.randint(1, 5)):
            if rng.random() < 0.15:
                formulas.append(rng.choice(atomless))
                continue
            atoms = rng.sample(vocabulary[: rng.randint(2, 12)], rng.randint(1, 2))
            formulas.append(random_formula(rng, atoms, rng.randint(2 * len(atoms), 7)))
        rule_set = RuleSet(formulas, vocabulary)
        dfas = [compile_formula(f, "one-hot") for f in formulas]
        expected = functools.reduce(DFA.product, dfas).minimize_nonempty()
        assert rule_set.dfa == expected, (case, formulas)
        assert rule_set.satisfiable == bool(expected.alive_letters(expected.initial).any())
        several += _group_count([d.atoms for d in dfas]) > 1
        unsatisfiable += not rule_set.satisfiable
    assert several > 60 and unsatisfiable > 5, (several, unsatisfiable)  # both kinds were tried


def test_a_groups_product_kept_for_its_automata_is_right_over_other_atoms() -> None:
    """A group's product is kept per (automata, atom layout) (`rule_set._GROUPS`): the same
    rules over other atoms, in the same or another order among the group's atoms, come out as
    the pairwise product of their own DFAs, the first layout from the kept table."""
    import functools

    from tleaf_cli.logic.compile import compile_formula
    from tleaf_cli.logic.dfa import DFA
    from tleaf_cli.rule_set import _GROUPS, RuleSet

    rules = ["G({x} -> F {y})", "!{y} U {x}", "G({y} -> X !{z})"]
    vocabulary = ["a", "b", "c", "d", "e", "f", "g", "h", "i"]
    names = [("a", "b", "c"), ("d", "e", "f"), ("i", "h", "g"), ("g", "i", "h")]
    for x, y, z in names:
        formulas = [r.format(x=x, y=y, z=z) for r in rules]
        before = len(_GROUPS)
        rule_set = RuleSet(formulas, vocabulary)
        dfas = [compile_formula(f, "one-hot") for f in formulas]
        assert rule_set.dfa == functools.reduce(DFA.product, dfas).minimize_nonempty(), (x, y, z)
        if (x, y, z) == ("d", "e", "f"):  # the layout of a, b, c: a copy of the kept table
            assert len(_GROUPS) == before
