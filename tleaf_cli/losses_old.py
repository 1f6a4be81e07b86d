"""Logic losses on a sequence model's outputs: how far its predictions are from the knowledge.

A model h reads a video and, at each step t, outputs action logits [A] and ingredient logits [I]
from independent heads. The distribution over (action, ingredient) pairs at step t is

    P_t(a, i) = softmax(action_logits_t)_a · softmax(ingredient_logits_t)_i .

Knowledge arrives as a rule set φ (a conjunction of LTLf rules over pair atoms such as
``cut_onion``), compiled to a DFA over the one-hot alphabet of its atoms: letter k+1 is
atoms[k], letter 0 is "none of them" (another pair of the domain). Step t's letter distribution is

    P_t(letter k+1) = P_t(atoms[k]),      P_t(letter 0) = 1 − Σ_k P_t(atoms[k]),

computed in log space (letter 0 as the log-sum of every other pair, not as a difference). The
losses, per video (each returns a [B] tensor; the trainer adds λ · mean to the task loss):

* ``tleaf``   ‖q(A_φ) − q(w̃)‖²: the paper's logic loss. q is the frozen embedder; w̃ is the soft
  trace whose step t carries the expected letter vector Σ_l P_t(l) q_e(l), so the loss is
  differentiable in the model's outputs.
* ``exact``   −log P(w ⊨ φ) with w drawn step by step from P_t: the forward algorithm over the DFA,
  exact because the steps are independent given the outputs.
* ``checker`` 1[argmax trace violates φ] (the exact checker on the predicted pairs). A 0/1
  penalty of a discrete prediction: it carries NO gradient and so cannot change training; it is
  kept because the paper compares against a model-checker loss.
* ``none``    0: the reference.

`RuleSets` turns a video's atoms into its rule set: the rules whose atoms all occur, conjoined,
compiled once per distinct set and, for ``tleaf``, embedded once (in-memory dicts keyed by the
rule set id), so the knowledge costs a dictionary lookup per video after the first sight.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from tleaf_cli.data.compile_dfas import CompileSettings, compile_sources
from tleaf_cli.data.dfa_table import dfa_from_row
from tleaf_cli.data.formula_files import FormulaSource
from tleaf_cli.data.knowledge import (
    KnowledgeBase,
    by_ingredient,
    rule_set_id,
    rules_for,
    sample_formula,
)
from tleaf_cli.embed.soft import Embedder, soft_trace_vectors
from tleaf_cli.errors import UsageError
from tleaf_cli.logic.checker import PackedDFAs
from tleaf_cli.logic.dfa import DFA

LOGIC_LOSSES = ("none", "tleaf", "checker", "exact")
NEG = -1e30  # log of "impossible": finite, so logsumexp and its gradient stay defined


@dataclass(frozen=True)
class RuleSet:
    """One conjunction of knowledge-base rules, compiled over the one-hot alphabet of its atoms.

    `pairs[k]` is the flat pair index (action · I + ingredient) of `dfa.atoms[k]`.
    """

    id: str
    formula: str
    num_rules: int
    dfa: DFA
    pairs: torch.Tensor  # long [k]
    satisfiable: bool  # some non-empty trace is accepted


class RuleSets:
    """Rule sets for the atoms of videos, each compiled once and (for tleaf) embedded once.

    `pair_index` maps every pair atom of the domain to its flat index. With an `embedder`,
    rules mentioning atoms outside q's vocabulary are left out (q cannot read them);
    `skipped_rules` counts how often that happened.
    """

    def __init__(
        self,
        kb: KnowledgeBase,
        pair_index: Mapping[str, int],
        embedder: Embedder | None = None,
        compile_settings: CompileSettings | None = None,
    ) -> None:
        self.kb = kb
        self.pair_index = dict(pair_index)
        self.embedder = embedder
        self.settings = compile_settings or CompileSettings(alphabet="one-hot")
        if self.settings.alphabet != "one-hot":
            raise ValueError("rule sets are compiled over the one-hot alphabet")
        self.known = set(embedder.vectors.index) if embedder is not None else None
        self.by_id: dict[str, RuleSet | None] = {}
        self._vectors: dict[str, torch.Tensor] = {}
        self._letters: dict[str, torch.Tensor] = {}
        self._rule_dfas: dict[str, DFA] = {}  # each rule's DFA, by rule name
        self.compiled = 0  # rule sets compiled (each distinct set once)
        self.skipped_rules = 0

    def rules(self, present_atoms: Collection[str]) -> list:
        """The KB rules whose atoms all occur in `present_atoms` (and that q can read)."""
        rules = rules_for(self.kb, present_atoms)
        if self.known is None:
            return rules
        kept = [r for r in rules if set(r.atoms) <= self.known]
        self.skipped_rules += len(rules) - len(kept)
        return kept

    def for_videos(self, atoms_per_video: Sequence[Collection[str]]) -> list[RuleSet | None]:
        """The rule set of each video (None where no rule applies)."""
        groups = self.groups_for_videos(atoms_per_video, per_ingredient=False)
        return [g[0] if g else None for g in groups]

    def groups_for_videos(
        self, atoms_per_video: Sequence[Collection[str]], per_ingredient: bool
    ) -> list[list[RuleSet]]:
        """Each video's rule sets: its whole rule set as one (`per_ingredient=False`) or one per
        ingredient (`knowledge.by_ingredient`); an empty list where no rule applies."""
        chosen = [self.rules(atoms) for atoms in atoms_per_video]
        groups = [by_ingredient(rules) if per_ingredient else [rules] for rules in chosen]
        ids = [[(rule_set_id(g), g) for g in gs if g] for gs in groups]
        fresh = {i: g for pairs in ids for i, g in pairs if i not in self.by_id}
        if fresh:
            self._compile(fresh)
        return [[self.by_id[i] for i, _ in pairs] for pairs in ids]

    def _compile(self, fresh: dict[str, list]) -> None:
        """Build each fresh rule set's DFA as the product of its rules' DFAs.

        Each rule is compiled by MONA once (through the compile cache); a rule set is then a
        product of small DFAs, minimised — the same minimal DFA MONA gives for the conjunction,
        without a MONA call per set (predicted pairs bring new sets every batch early on).
        """
        rules = {r.name: r for rs in fresh.values() for r in rs if r.name not in self._rule_dfas}
        if rules:
            sources = [
                FormulaSource(n, r.formula, "knowledge base", f"rule {n}") for n, r in rules.items()
            ]
            report = compile_sources(sources, self.settings)
            for src, row in zip(sources, report.rows, strict=True):
                if row["error"] is not None:
                    raise UsageError(f"knowledge base: rule {src.formula_id}: {row['error']}")
                self._rule_dfas[src.formula_id] = dfa_from_row(row)
        for rid, rs in fresh.items():
            names = sorted(r.name for r in rs)
            dfa = self._rule_dfas[names[0]]
            for name in names[1:]:
                dfa = dfa.intersect(self._rule_dfas[name])
            dfa = dfa.minimize_nonempty()
            missing = [a for a in dfa.atoms if a not in self.pair_index]
            if missing:
                raise UsageError(
                    f"knowledge base: rule atoms {missing} are not (action, ingredient) pairs "
                    "of the activities' vocabularies"
                )
            pairs = torch.tensor([self.pair_index[a] for a in dfa.atoms], dtype=torch.long)
            satisfiable = bool(len(_reachable_accepting(dfa)))
            self.by_id[rid] = RuleSet(rid, sample_formula(rs), len(rs), dfa, pairs, satisfiable)
        self.compiled += len(fresh)

    def embed(self, rule_sets: Sequence[RuleSet | None]) -> None:
        """Embed every rule set not seen before: q(A_φ) and q_e of its letters, in batches.

        The letters of all fresh sets go through q_e together, their guards too, and their DFAs
        through q_m together, so a batch full of new rule sets costs three encoder calls, not
        three per set.
        """
        fresh = list(
            {r.id: r for r in rule_sets if r is not None and r.id not in self._vectors}.values()
        )
        if not fresh:
            return
        q = self._need_embedder()
        q.vectors([k for r in fresh for k in q.letter_keys(r.dfa.atoms, "one-hot")[1]])
        if q.kind == "dfa":
            vectors = q.embed_dfas([r.dfa for r in fresh])
        else:  # the syntax-tree baseline reads the formula's text
            rows = [{"formula": r.formula, "atoms": r.dfa.atoms} for r in fresh]
            vectors = q.embed_formula_rows(rows)
        for r, vector in zip(fresh, vectors, strict=True):
            self._vectors[r.id] = vector
            self._letters[r.id] = q.letter_vectors(r.dfa.atoms, "one-hot")[1]

    def formula_vector(self, rule_set: RuleSet) -> torch.Tensor:
        """q(A_φ) [d], embedded once per rule set (no gradient: q is frozen)."""
        self.embed([rule_set])
        return self._vectors[rule_set.id]

    def letter_vectors(self, rule_set: RuleSet) -> torch.Tensor:
        """q_e of the letters (none, atoms[0], ...) [k+1, d_e], once per rule set."""
        self.embed([rule_set])
        return self._letters[rule_set.id]

    def _need_embedder(self) -> Embedder:
        if self.embedder is None:
            raise ValueError("the tleaf loss needs an embedder (RuleSets(..., embedder=q))")
        return self.embedder


def _reachable_accepting(dfa: DFA) -> np.ndarray:
    """Accepting states reachable from the initial state in at least one step."""
    seen = np.zeros(dfa.num_states, dtype=bool)
    frontier = np.unique(dfa.table[dfa.initial])
    while len(frontier):
        seen[frontier] = True
        nxt = np.unique(dfa.table[frontier])
        frontier = nxt[~seen[nxt]]
    return np.flatnonzero(seen & dfa.accepting)


# --------------------------------------------------------------------------- distributions


def pair_log_probs(action_logits: torch.Tensor, ingredient_logits: torch.Tensor) -> torch.Tensor:
    """log P_t(a, i) = log_softmax_a + log_softmax_i, flattened: [..., T, A·I] (pair a·I + i)."""
    la = torch.log_softmax(action_logits, dim=-1)
    li = torch.log_softmax(ingredient_logits, dim=-1)
    joint = la.unsqueeze(-1) + li.unsqueeze(-2)
    return joint.flatten(-2)


def letter_log_probs(log_pairs: torch.Tensor, pairs: torch.Tensor) -> torch.Tensor:
    """[T, k+1] one-hot letter log-probabilities of one video over a rule set's atoms.

    Column k+1 is log P(atoms[k]); column 0 is the log-sum of every other pair (exact, where
    1 − Σ would lose precision when the atoms hold almost all the mass).
    """
    others = log_pairs.clone()
    others[:, pairs] = NEG
    return torch.cat([torch.logsumexp(others, dim=1, keepdim=True), log_pairs[:, pairs]], dim=1)


# --------------------------------------------------------------------------- the losses


def _trainable(rule_sets: Sequence[RuleSet | None]) -> list[int]:
    """Videos with a rule set that some trace satisfies: the others give no training signal
    (−log 0 is infinite; an unsatisfiable φ has no region in q's space to pull towards)."""
    return [b for b, r in enumerate(rule_sets) if r is not None and r.satisfiable]


def no_logic_loss(action_logits: torch.Tensor, *_args, **_kwargs) -> torch.Tensor:
    """The reference: zero for every video, [B]."""
    return action_logits.new_zeros(action_logits.shape[0])


def exact_loss(
    action_logits: torch.Tensor,
    ingredient_logits: torch.Tensor,
    lengths: torch.Tensor,
    rule_sets: Sequence[RuleSet | None],
) -> torch.Tensor:
    """−log P(the DFA accepts), per video [B]; 0 where no rule applies.

    Forward algorithm over padded DFAs (states S, letters L, batch together):
    α_0 = 1[initial], α_t(s') = Σ_{s, l: δ(s, l) = s'} α_{t−1}(s) P_t(l), and
    P(accept) = Σ_{s ∈ F} α_T(s). Outputs are independent across steps given the inputs, so this
    is the exact probability that a trace sampled from the per-step distributions satisfies φ.
    Each step scatters the S·L terms into their target states (O(S·L), not the O(S·L·S) of a
    transition tensor: whole-video rule sets reach hundreds of states), as a log-sum-exp per
    target state, so a trace the model is sure violates φ still has a finite loss and a gradient.
    """
    out = action_logits.new_zeros(action_logits.shape[0])
    which = _trainable(rule_sets)
    if not which:
        return out
    sets = [rule_sets[b] for b in which]
    log_pairs = pair_log_probs(action_logits[which], ingredient_logits[which])
    n, steps = len(which), log_pairs.shape[1]
    states = max(r.dfa.num_states for r in sets)
    letters = max(r.dfa.alphabet.size for r in sets)
    device = log_pairs.device

    log_letters = log_pairs.new_full((n, steps, letters), NEG)
    # δ(s, l) per video, flattened over (s, l); padded states and letters lead to a sink state
    targets = torch.full((n, states, letters), states, dtype=torch.long, device=device)
    accepting = torch.zeros((n, states), dtype=torch.bool, device=device)
    alpha = log_pairs.new_full((n, states), NEG)
    for j, r in enumerate(sets):
        k, s = r.dfa.alphabet.size, r.dfa.num_states
        log_letters[j, :, :k] = letter_log_probs(log_pairs[j], r.pairs.to(device))
        targets[j, :s, :k] = torch.as_tensor(r.dfa.table, dtype=torch.long, device=device)
        accepting[j, :s] = torch.as_tensor(r.dfa.accepting, device=device)
        alpha[j, r.dfa.initial] = 0.0
    targets = targets.flatten(1)

    lengths = lengths[which].to(device)
    neg = log_pairs.new_tensor(NEG)
    for t in range(int(lengths.max())):
        terms = (alpha[:, :, None] + log_letters[:, t, None, :]).flatten(1)  # [n, S·L]
        top = log_pairs.new_full((n, states + 1), NEG)
        top = top.scatter_reduce(1, targets, terms.detach(), "amax")
        sums = log_pairs.new_zeros((n, states + 1))
        sums = sums.scatter_add(1, targets, (terms - top.gather(1, targets)).exp())
        step = (top + sums.clamp(min=1.0).log())[:, :states]  # a reached state's sum is >= 1
        alpha = torch.where((t < lengths)[:, None], step, alpha)
    out[which] = -torch.logsumexp(torch.where(accepting, alpha, neg), dim=1)
    return out


def tleaf_loss(
    action_logits: torch.Tensor,
    ingredient_logits: torch.Tensor,
    lengths: torch.Tensor,
    rule_sets: Sequence[RuleSet | None],
    cache: RuleSets,
) -> torch.Tensor:
    """‖q(A_φ) − q(w̃)‖² per video [B] (the paper's ℓ_logic); 0 where no rule applies.

    w̃ is the soft trace of the outputs: step t's edge node carries Σ_l P_t(l) q_e(l) over the
    one-hot letters of φ's atoms. q is frozen; gradients reach the model through P_t. All videos
    of a batch go through q_m in one graph batch; q(A_φ) and q_e(letters) come from `cache`.
    """
    out = action_logits.new_zeros(action_logits.shape[0])
    which = _trainable(rule_sets)
    if not which:
        return out
    embedder = cache._need_embedder()
    cache.embed([rule_sets[b] for b in which])
    device = action_logits.device
    log_pairs = pair_log_probs(action_logits[which], ingredient_logits[which])
    expected, targets = [], []
    for j, b in enumerate(which):
        r = rule_sets[b]
        probs = letter_log_probs(log_pairs[j], r.pairs.to(device)).exp()  # padded steps unread
        expected.append(probs @ cache.letter_vectors(r).to(device))
        targets.append(cache.formula_vector(r).to(device))
    rows = torch.tensor(which, device=lengths.device)
    z_trace = soft_trace_vectors(embedder.model, torch.stack(expected), lengths[rows].to(device))
    out[which] = (z_trace - torch.stack(targets)).pow(2).sum(dim=1)
    return out


def grouped(
    loss: Callable[..., torch.Tensor],
    action_logits: torch.Tensor,
    ingredient_logits: torch.Tensor,
    lengths: torch.Tensor,
    groups: Sequence[Sequence[RuleSet]],
    *args,
) -> torch.Tensor:
    """Σ over each video's rule sets of `loss` [B] (0 for a video without any): with one set per
    ingredient, ℓ(φ) = Σ_x ℓ(φ_x). The video's outputs are repeated once per set, so every set
    is one row of a single call of `loss`."""
    out = action_logits.new_zeros(action_logits.shape[0])
    owner = [b for b, sets in enumerate(groups) for _ in sets]
    if not owner:
        return out
    rows = torch.tensor(owner, device=action_logits.device)
    flat = [r for sets in groups for r in sets]
    per_set = loss(
        action_logits[rows], ingredient_logits[rows], lengths[rows.to(lengths.device)], flat, *args
    )
    return out.index_add(0, rows, per_set)


def checker_loss(
    action_logits: torch.Tensor,
    ingredient_logits: torch.Tensor,
    lengths: torch.Tensor,
    rule_sets: Sequence[RuleSet | None],
) -> torch.Tensor:
    """1 if the argmax trace violates φ (the exact checker), else 0, per video [B].

    The paper's model-checker loss. The argmax is not differentiable: this returns a constant
    with NO gradient, so adding it to the objective leaves training unchanged (same updates as
    the reference); it is kept because the paper reports it as a comparison.
    """
    out = action_logits.new_zeros(action_logits.shape[0])
    which = [b for b, r in enumerate(rule_sets) if r is not None]
    if not which:
        return out
    with torch.no_grad():
        pairs = pair_log_probs(action_logits, ingredient_logits).argmax(dim=-1).cpu().numpy()
    sequences = [pairs[b, : int(lengths[b])] for b in which]
    bad = violations([rule_sets[b] for b in which], sequences)
    out[which] = torch.as_tensor(bad, dtype=out.dtype, device=out.device)
    return out


def violations(rule_sets: Sequence[RuleSet], pair_sequences: Sequence[np.ndarray]) -> np.ndarray:
    """bool [n]: sequence i (flat pair indices) violates rule_sets[i] (the batched checker)."""
    if not rule_sets:
        return np.zeros(0, dtype=bool)
    width = max(len(p) for p in pair_sequences)
    letters = np.zeros((len(rule_sets), width), dtype=np.int64)
    for i, (r, seq) in enumerate(zip(rule_sets, pair_sequences, strict=True)):
        code = {int(p): k + 1 for k, p in enumerate(r.pairs.tolist())}
        letters[i, : len(seq)] = [code.get(int(p), 0) for p in seq]
    packed = PackedDFAs([r.dfa for r in rule_sets])
    lengths = np.array([len(p) for p in pair_sequences])
    return ~packed.check(np.arange(len(rule_sets)), letters, lengths)
