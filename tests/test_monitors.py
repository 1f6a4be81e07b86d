"""Temporal monitors (`train-meta --monitors`): each monitor against LTLf semantics, a DFA's
shares against listing its words, the soft (torch) features against the crisp ones."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import torch

from tleaf_cli.embed.soft_monitors import (
    AlphabetWalk,
    monitor_classes,
    soft_monitor_features,
    soft_monitor_walk,
)
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.monitors import MonitorBank
from tleaf_cli.logic.semantics import satisfies

# each pattern as the LTLf formula it stands for (P, Q: the monitor's literals)
PATTERNS = {
    "F": "F(P)",
    "G": "G(P)",
    "at1": "P",
    "at2": "X(P)",
    "at3": "X(X(P))",
    "last": "F(P & last)",
    "before_last": "F(P & X(last))",
    "U": "(P U Q)",
    "F_and_X": "F(P & X(Q))",
    "G_X": "G(P -> X(Q))",
    "G_F": "G(P -> F(Q))",
    "F_and": "F(P & Q)",
}
ATOMS = ("a", "b", "c")


def _formula(monitor) -> str:
    p, q = (
        ("" if sign else "!") + ATOMS[slot]
        for sign, slot in zip(monitor.signs, monitor.slots, strict=True)
    )
    return PATTERNS[monitor.name].replace("P", f"({p})").replace("Q", f"({q})")


def test_every_monitor_accepts_the_words_its_formula_holds_on():
    bank = MonitorBank(3)
    assert bank.width == 7 * 3 + 18 * 3 * 2
    alphabet = Alphabet(ATOMS)
    rng = np.random.default_rng(0)
    words = [rng.integers(0, alphabet.size, size=rng.integers(1, 7)) for _ in range(150)]
    features = np.stack([bank.of_word(alphabet.truth(), w) for w in words])
    for k, monitor in enumerate(bank.monitors):
        formula = parse(_formula(monitor))
        expected = [satisfies([alphabet.letter(i) for i in w], formula) for w in words]
        assert features[:, k].tolist() == [float(x) for x in expected], str(monitor)


@pytest.mark.parametrize(
    "formula", ["G(a -> X(b))", "(a U b) <-> F(c)", "X(a) | G(!b)", "F(a & b)"]
)
@pytest.mark.parametrize("ranges", [1, 2])
def test_a_dfas_shares_are_those_of_its_listed_words(formula, ranges):
    """Per length range (lengths 1-2 and 3-4 with 2 ranges), the mean over its lengths of the
    share of accepted / rejected words each monitor accepts; a word fills its own range."""
    dfa = compile_formula(formula)
    bank = MonitorBank(3, max_length=4, ranges=ranges)
    truth = dfa.alphabet.truth()
    expected, counted = np.zeros((2, bank.features)), np.zeros((2, bank.features))
    for length in range(1, 5):
        words: list[list[np.ndarray]] = [[], []]
        for w in itertools.product(range(dfa.alphabet.size), repeat=length):
            words[0 if dfa.accepting[dfa.run(w)] else 1].append(bank.of_word(truth, w))
        block = np.zeros(bank.features, dtype=bool)
        block[bank.range_of(length) * bank.width : (bank.range_of(length) + 1) * bank.width] = 1
        assert not np.stack(words[0] + words[1])[:, ~block].any()
        for row in (0, 1):
            if words[row]:
                expected[row] += np.mean(words[row], axis=0)
                counted[row] += block
    expected /= np.maximum(counted, 1)
    np.testing.assert_allclose(bank.of_dfa(dfa), expected, atol=1e-6)


def test_missing_atom_slots_read_zero_and_extra_atoms_are_ignored():
    bank = MonitorBank(3)
    dfa = compile_formula("F(a) & G(b)")  # two atoms: slot 2 is empty
    shares = bank.of_dfa(dfa)
    uses_slot_2 = np.array([2 in m.slots for m in bank.monitors])
    assert (shares[:, uses_slot_2] == 0).all() and (shares[0, ~uses_slot_2] > 0).any()
    small = MonitorBank(1)  # reads atom a only, of any alphabet
    assert small.of_dfa(compile_formula("F(a) & G(b)")).shape == (2, small.width)


@pytest.mark.parametrize("ranges", [1, 3])
def test_soft_features_of_one_hot_letters_are_the_crisp_ones_and_carry_gradients(ranges):
    bank = MonitorBank(2, max_length=6, ranges=ranges)
    alphabet = Alphabet(("a", "b"), "one-hot")
    classes, present = monitor_classes(bank, alphabet.truth())
    rng = np.random.default_rng(1)
    words = [rng.integers(0, alphabet.size, size=n) for n in (1, 3, 5)]
    probs = torch.zeros(3, 5, alphabet.size)
    for n, w in enumerate(words):
        probs[n, torch.arange(len(w)), torch.from_numpy(w)] = 1.0
    lengths = torch.tensor([len(w) for w in words])
    soft = soft_monitor_features(
        bank, probs, lengths, classes.expand(3, -1, -1), present.expand(3, -1)
    )
    crisp = torch.stack([torch.from_numpy(bank.of_word(alphabet.truth(), w)) for w in words])
    torch.testing.assert_close(soft[:, : bank.features], crisp)
    assert (soft[:, bank.features :] == 0).all()
    logits = torch.zeros(1, 4, alphabet.size, requires_grad=True)
    out = soft_monitor_features(
        bank, logits.softmax(-1), torch.tensor([4]), classes[None], present[None]
    )
    out[0, : bank.features].sum().backward()
    assert logits.grad.abs().sum() > 0
    assert ((out >= 0) & (out <= 1 + 1e-6)).all()


def test_soft_features_of_mixed_alphabets_are_each_monitors_own_walk():
    """Traces over alphabets of 1..3 atoms in one batch of a 3-slot bank (only the pairs whose
    atoms exist are run): each feature is the monitor's state distribution walked step by step
    with its table, and a missing atom's monitors read 0."""
    bank = MonitorBank(3, max_length=6)
    rng = np.random.default_rng(4)
    sizes, lengths = [1, 3, 2, 3], [6, 2, 4, 1]
    tables = [
        monitor_classes(bank, Alphabet(("a", "b", "c")[:k], "one-hot").truth()) for k in sizes
    ]
    classes = torch.zeros(len(sizes), bank.width, 4, dtype=torch.long)
    for row, (c, _) in enumerate(tables):
        classes[row, :, : c.shape[1]] = c
    present = torch.stack([p for _, p in tables])
    probs = torch.zeros(len(sizes), 6, 4, dtype=torch.float64)
    for row, k in enumerate(sizes):
        probs[row, :, : k + 1] = torch.from_numpy(rng.dirichlet(np.ones(k + 1), size=6))
    out = soft_monitor_features(bank, probs, torch.tensor(lengths), classes, present)
    for row, k in enumerate(sizes):
        for m in range(bank.width):
            state = np.eye(5)[0]
            for t in range(lengths[row]):
                moved = np.zeros(5)
                for letter in range(k + 1):
                    c = int(classes[row, m, letter])
                    np.add.at(moved, bank.tables[m, :, c], state * float(probs[row, t, letter]))
                state = moved
            want = float(state @ bank.accepting[m]) if present[row, m] else 0.0
            assert float(out[row, m]) == pytest.approx(want, abs=1e-12)
    assert present.sum() < present.numel()  # some monitors are missing, and read 0 above


def test_soft_walk_gradients_are_the_numerical_ones():
    """The walk's hand-written backward (`soft_monitor_walk`) against finite differences, on
    traces over alphabets of 1..3 atoms, one-hot and powerset, some shorter than the batch."""
    bank = MonitorBank(3, max_length=6, ranges=2)
    alphabets = [Alphabet(("a", "b", "c")[:k], kind) for k, kind in
                 [(1, "one-hot"), (3, "one-hot"), (2, "powerset"), (3, "one-hot")]]  # fmt: skip
    walks = [AlphabetWalk.of(bank, *monitor_classes(bank, a.truth())) for a in alphabets]
    rng = np.random.default_rng(7)
    width = max(a.size for a in alphabets)
    probs = torch.zeros(len(alphabets), 4, width, dtype=torch.float64)
    for row, a in enumerate(alphabets):
        probs[row, :, : a.size] = torch.from_numpy(rng.dirichlet(np.ones(a.size), size=4))
    probs.requires_grad_()
    lengths = torch.tensor([4, 2, 3, 1])
    weights = torch.from_numpy(rng.normal(size=2 * bank.features))  # a random readout of them
    torch.autograd.gradcheck(
        lambda p: soft_monitor_walk(bank, p, lengths, walks) @ weights, probs, atol=1e-8
    )


@pytest.fixture(scope="module")
def monitor_q(chain, tmp_path_factory):
    """A small q with monitors trained through train-meta, and what train-meta reported."""
    from tleaf_cli.embed.train_meta import MetaSettings, train_meta

    out = tmp_path_factory.mktemp("q") / "m"
    settings = MetaSettings.preset(
        "paper", hidden=16, layers=1, out_dim=8, epochs=3, patience=3, batch_size=32, lr=3e-3,
        directed=True, readout="runs", bins=2, monitors=3, radius_weight=1.0,
    )  # fmt: skip
    metrics = train_meta(chain["dfas"], chain["traces"], chain["edge"], out, settings)
    return out, metrics


def test_a_q_with_monitors_trains_saves_and_reloads_identically(chain, monitor_q) -> None:
    from test_run_readout import _held_out_accuracy

    from tleaf_cli.embed.load import load_embedder

    out, metrics = monitor_q
    assert metrics["history"][-1]["loss"] < metrics["history"][0]["loss"]
    q = load_embedder(out)
    assert q.model.trace.monitor_bank.width == MonitorBank(3).width
    reloaded = _held_out_accuracy(q, chain["dfas"], chain["traces"])
    assert reloaded == pytest.approx(metrics["test"]["triplet_accuracy"], abs=1e-6)
    # the monitor block moves the vectors: the same traces with the block zeroed embed elsewhere
    head = q.model.trace.head.weight
    assert head[:, -q.model.trace.monitor_width :].abs().sum() > 0


def test_soft_traces_and_the_tleaf_loss_read_the_monitors(monitor_q) -> None:
    import tleaf_cli as tl
    from tleaf_cli.embed.load import load_embedder

    q = load_embedder(monitor_q[0])
    atoms = ("a", "b", "c")
    trace = [{"b"}, set(), {"a"}, {"c"}]
    probs = torch.tensor([[0.0, 1, 0], [0, 0, 0], [1, 0, 0], [0, 0, 1]])
    for domain in ("one-hot", "powerset"):
        crisp = q.embed_traces([trace], [atoms], one_hot=domain == "one-hot")[0]
        soft = q.embed_soft_trace(probs, atoms, domain=domain)
        torch.testing.assert_close(soft, crisp, atol=1e-5, rtol=1e-5)
    rules = tl.RuleSet("G(a -> F(b))", list(atoms))
    logits = torch.randn(3, 5, len(atoms), requires_grad=True)
    loss = tl.logic_loss("tleaf", torch.log_softmax(logits, -1), rules, embedder=q)
    loss.backward()
    assert loss.item() > 0 and logits.grad.abs().sum() > 0


def test_only_whole_dfa_files_keep_their_shares_on_disk(chain, monitor_q, _isolated_cache):
    """A loss's rule sets (fresh subsets each batch) write no share file; a dfas.parquet's rows
    (train-meta, every evaluation) write one, and embed the same when read back from it."""
    import tleaf_cli as tl
    from tleaf_cli.data.dfa_table import read_dfas
    from tleaf_cli.embed.load import load_embedder

    q = load_embedder(monitor_q[0])
    q.rule_set_vectors([tl.RuleSet("G(a -> F(b))", ["a", "b", "c"])])
    assert not (_isolated_cache / "monitors").exists()
    rows = [r for r in read_dfas(chain["dfas"]).rows if r["error"] is None]
    first = q.embed_formula_rows(rows)
    assert len(list((_isolated_cache / "monitors").glob("*.npy"))) == 1
    again = load_embedder(monitor_q[0]).embed_formula_rows(rows)
    # to float rounding: with several torch threads two forwards differ by ~1e-8 (reduction order)
    torch.testing.assert_close(again, first, rtol=1e-6, atol=1e-6)


def test_cli_refuses_monitors_for_the_syntax_baseline(chain, chain_cli, tmp_path) -> None:
    args = ["train-meta", chain["dfas"], chain["traces"], "--edge", chain["edge"]]
    result = chain_cli(*args, "-o", tmp_path / "q", "--embedder", "syntax", "--monitors", 3)
    assert result.exit_code != 0 and "--monitors: only with the dfa embedder" in result.output
    assert not (tmp_path / "q").exists()


# Declare-style rules over a one-hot domain (the action-recognition knowledge base's kinds)
_RULES = (
    "G({a} -> F({b}))",  # response
    "((!{b} U {a}) | G(!{b}))",  # precedence
    "G(!{a})",  # absence
    "F({a})",  # existence
    "G({a} -> X({b}))",  # chain response
    "(!{a} U {b})",
)


def _one_hot_rule_sets(seed: int, count: int) -> list[str]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        atoms = [f"x{k}" for k in range(rng.integers(2, 9))]
        parts = []
        for _ in range(rng.integers(1, 4)):
            a, b = rng.choice(atoms, size=2, replace=False)
            parts.append(_RULES[rng.integers(len(_RULES))].format(a=a, b=b))
        out.append(" & ".join(parts))
    return out


@pytest.mark.parametrize(
    ("slots", "max_length", "ranges"), [(1, 5, 1), (3, 9, 2), (5, 12, 3), (8, 7, 1)]
)
def test_one_hot_shares_are_those_of_the_general_path(slots, max_length, ranges):
    """`of_dfa` over one-hot alphabets (three letter kinds per monitor, a backward pass) gives
    the general path's shares, with fewer, as many and more atoms than slots."""
    bank = MonitorBank(slots, max_length=max_length, ranges=ranges)
    for text in _one_hot_rule_sets(slots, 25):
        dfa = compile_formula(text, alphabet="one-hot")
        assert bank._one_hot_plan(dfa.alphabet.truth()) is not None
        fast, general = bank.of_dfa(dfa), bank.of_dfa(dfa, general=True)
        assert fast.dtype == np.float32 and fast.shape == (2, bank.features)
        assert np.allclose(fast, general, atol=1e-6), text


def test_powerset_alphabets_take_the_general_path():
    bank = MonitorBank(2, max_length=5)
    dfa = compile_formula("G(a -> F(b))")
    assert dfa.alphabet.kind == "powerset"
    assert np.array_equal(bank.of_dfa(dfa), bank.of_dfa(dfa, general=True))


def test_the_rest_walk_of_a_large_dfa_is_the_dense_product():
    """Large DFAs (few distinct successors per state) take a gather per successor instead of
    the dense product with the letter counts: the same sums."""
    from tleaf_cli.logic.letter_walks import rest_walk

    rng = np.random.default_rng(0)
    n, letters = 200, 12
    table = np.where(rng.random((n, letters)) < 0.8, rng.integers(0, n, (n, 1)), 0)
    counts = np.zeros((n, n))
    np.add.at(counts, (np.arange(n)[:, None], table), 1.0)
    beta = rng.random((7, 2, n))
    np.testing.assert_allclose(rest_walk(counts)(beta), beta @ counts.T, rtol=1e-12)


def test_the_table_walk_is_the_dense_product() -> None:
    """`table_walk` reads a DFA's table without building the [n, n] letter counts."""
    from tleaf_cli.logic.letter_walks import rest_walk, table_walk

    rng = np.random.default_rng(1)
    n, letters = 150, 9
    table = np.where(rng.random((n, letters)) < 0.7, rng.integers(0, n, (n, 1)), 3)
    table[:, 0] = rng.integers(0, n, n)
    counts = np.zeros((n, n))
    np.add.at(counts, (np.arange(n)[:, None], table), 1.0)
    beta = rng.random((5, 2, n))
    np.testing.assert_allclose(table_walk(table)(beta), beta @ counts.T, rtol=1e-12)
    np.testing.assert_allclose(table_walk(table)(beta), rest_walk(counts)(beta), rtol=1e-12)


def test_large_dfas_get_their_shares_without_dense_moves(monkeypatch) -> None:
    """A recipe's precedence rules conjoined (12,401 states over 24 letters) asked 27.5 GiB
    for the dense one-hot moves [letters, n, n]; above `DENSE_MOVES` entries the table is
    walked instead, with the same shares."""
    import tleaf_cli.logic.monitors as monitors

    texts = [f"(!x{b} U x{a}) | G !x{b}" for a, b in ((0, 3), (1, 3), (2, 4), (3, 5), (4, 5))]
    dfa = compile_formula(" & ".join(texts), alphabet="one-hot")
    dense = MonitorBank(4, max_length=9, ranges=2).of_dfa(dfa)
    monkeypatch.setattr(monitors, "DENSE_MOVES", 0)
    walked = MonitorBank(4, max_length=9, ranges=2).of_dfa(dfa)
    assert dfa.num_states > 8 and walked.dtype == np.float32
    np.testing.assert_allclose(walked, dense, rtol=1e-5, atol=1e-7)


def test_shares_are_kept_per_automaton_whatever_its_atoms() -> None:
    """`of_dfa` of the same automaton over other atoms is the first one's (kept, not
    recomputed), a caller's edits do not reach the kept copy, and another automaton over the
    same atoms gets its own shares."""
    bank = MonitorBank(2, max_length=5)
    first = compile_formula("G(a -> F b)", "one-hot")
    renamed = compile_formula("G(c -> F d)", "one-hot")
    other = compile_formula("F(a & X b)", "one-hot")
    assert np.array_equal(first.table, renamed.table) and first.atoms != renamed.atoms
    shares = bank.of_dfa(first)
    shares[:] = -1.0  # the caller's copy
    again = bank.of_dfa(renamed)
    np.testing.assert_allclose(again, bank.of_dfa(first, general=True), rtol=1e-6, atol=1e-7)
    assert (again >= 0).all() and not np.array_equal(again, bank.of_dfa(other))


def test_automata_over_other_atoms_share_readout_weights_and_embed_as_alone(monitor_q) -> None:
    """The readout weights kept per automaton (`DFA.structure`) give each DFA the vector a q
    that never saw the other gives it; guards over other atoms still get their own q_e."""
    import tleaf_cli as tl
    from tleaf_cli.embed.load import load_embedder

    ab = tl.RuleSet("G(a -> F(b))", ["a", "b", "c"]).dfa
    ac = tl.RuleSet("G(a -> F(c))", ["a", "b", "c"]).dfa  # the same automaton over (a, c)
    assert ab.structure == ac.structure and ab.atoms != ac.atoms
    q = load_embedder(monitor_q[0])
    both = q.embed_dfas([ab, ac])
    assert len(q._run_weights) == 1
    for k, dfa in enumerate((ab, ac)):
        torch.testing.assert_close(both[k], load_embedder(monitor_q[0]).embed_dfas([dfa])[0])
    assert not torch.allclose(both[0], both[1])


def test_guard_vectors_are_kept_by_the_names_a_guard_reads(monitor_q) -> None:
    """A guard over positions of different atom lists is one q_e vector when it reads the same
    atoms (computed once), and another when it reads others."""
    from tleaf_cli.embed.load import load_embedder

    vectors = load_embedder(monitor_q[0]).vectors
    a_not_b = ((1,), (-2,))  # a & !b over (a, b, ...), by position
    first = vectors([(("a", "b"), a_not_b)])
    again = vectors([(("a", "b", "c"), a_not_b)])
    assert len(vectors.cache) == 1 and torch.equal(first, again)
    swapped = vectors([(("b", "a"), a_not_b)])  # b & !a
    assert len(vectors.cache) == 2 and not torch.allclose(first, swapped)
