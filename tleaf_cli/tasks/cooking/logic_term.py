"""The logic term of GAIL on Creative Cooking: the policy's action distributions against the rules.

Rule sets, as the paper extracts them ("the related clauses for the current ingredient"): for
each of an episode's five ingredients x, the knowledge-base rules (tleaf_cli.tasks.cooking.
knowledge, mixture rules left out) whose atoms are all actions applied to x — `wash_x`, `fry_x`,
`combine_x_y`, `top_with_x_y` — conjoined and compiled over the one-hot alphabet of their atoms.
Rules that also name another ingredient's actions (the second argument's ordering of a combine)
fall outside every set.

Soft traces: in an episode's observations s_1..s_T the policy gives π(·|s_t) over the 234 action
ids; in this episode each id is exactly one atom (`env.action_names`), so the episode's action
names are the vocabulary of `losses.logic_loss` and its log π are the `log_probs` (the empty
letter of x's rule set carries every other action's mass):

* exact  : −log P(trace ⊨ φ_x), the forward algorithm;
* tleaf  : ‖q(A_φx) − q(w̃)‖², q frozen;
* checker: 1[the actions the rollout sampled violate φ_x] — a constant, no gradient.

Every rule here is a safety property (`G !a`, "a before b"), so an episode's prefix that
violates φ_x violates it for good; episodes are scored from their first step only (see
`rollout_episodes`), because a DFA run must start in the initial state.

Everything heavy is cached: one `KnowledgeRuleSets` per ingredient set, which builds each
distinct rule set once (MONA per rule, plus compile-dfa's disk cache), and q embeds each rule set
once. A minibatch's term is one policy forward over its episodes and one `logic_loss` call over
all its (episode, ingredient) rows.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch

from tleaf_cli.data.compile_dfas import CompileSettings
from tleaf_cli.errors import SettingError
from tleaf_cli.knowledge.base import KnowledgeBase
from tleaf_cli.knowledge.base import Rule as KbRule
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.logic.formulas import atoms, parse
from tleaf_cli.losses import logic_loss, violates
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.tasks.cooking.domain import Domain
from tleaf_cli.tasks.cooking.knowledge import knowledge_base
from tleaf_cli.tasks.cooking.rules import NUM_SLOTS, ActionCodec, EpisodeRules

if TYPE_CHECKING:  # torch-geometric's 2 s of import only where the tleaf loss loads one
    from tleaf_cli.embed.embedder import Embedder

GRADIENT_LOSSES = ("tleaf", "exact")


@dataclass(frozen=True)
class RolloutEpisode:
    """An episode (or its first part) from a rollout: observations [T, 12], sampled actions [T]."""

    ingredients: tuple[str, ...]
    observations: np.ndarray
    actions: np.ndarray


@dataclass(frozen=True)
class IngredientRules:
    """The rule sets of one ingredient set: `sets[k]` for slot k+1 (None: no rule applies);
    `trainable`: the satisfiable ones, in slot order (the rows of the logic term)."""

    rule_sets: KnowledgeRuleSets
    sets: tuple[RuleSet | None, ...]
    trainable: tuple[RuleSet, ...]


class CookingKnowledge:
    """Per ingredient set, its per-ingredient rule sets over this episode's action ids (cached)."""

    def __init__(
        self,
        domain: Domain,
        embedder: Embedder | None = None,
        compile_settings: CompileSettings | None = None,
    ) -> None:
        self.domain = domain
        self.embedder = embedder
        self.settings = compile_settings or CompileSettings(alphabet="one-hot")
        self.codec = ActionCodec(domain)
        self._by_set: dict[tuple[str, ...], IngredientRules] = {}

    def rules(self, ingredients: Sequence[str]) -> IngredientRules:
        key = tuple(ingredients)
        if key not in self._by_set:
            self._by_set[key] = self._build(key)
        return self._by_set[key]

    def _build(self, ingredients: tuple[str, ...]) -> IngredientRules:
        members = sorted((self.domain.ingredient(n) for n in ingredients), key=lambda i: i.index)
        names = EpisodeRules(self.domain, members, self.codec).action_names
        kb = KnowledgeBase(
            tuple(
                KbRule(r.name, r.kind, r.formula, atoms(parse(r.formula)))  # type: ignore[arg-type]
                for r in knowledge_base(self.domain, ingredients, mixture=False)
            )
        )
        known = None if self.embedder is None else set(self.embedder.vectors.index)
        rule_sets = KnowledgeRuleSets(kb, names, known, self.settings)
        on_slot = [
            [names[i] for i, (_, slots) in enumerate(self.codec.table) if slots[0] == slot]
            for slot in range(1, NUM_SLOTS)
        ]
        sets = tuple(rule_sets.one_each(on_slot))
        trainable = tuple(r for r in sets if r is not None and r.satisfiable)
        return IngredientRules(rule_sets, sets, trainable)


def rollout_episodes(
    observations: np.ndarray, actions: np.ndarray, episode_starts: np.ndarray, domain: Domain
) -> list[RolloutEpisode]:
    """Split a rollout buffer's [n_steps, n_envs, ...] arrays into the episodes that START in it.

    An episode cut by the rollout's end is kept up to the cut (a prefix); the part of an episode
    that started in an earlier rollout is dropped (its DFA state at the cut is unknown).
    """
    names = [i.name for i in domain.ingredients]
    out = []
    for env in range(observations.shape[1]):
        starts = np.flatnonzero(episode_starts[:, env])
        ends = [*starts[1:], observations.shape[0]]
        for a, b in zip(starts, ends, strict=True):
            obs = observations[a:b, env].astype(np.int64)
            ingredients = tuple(names[i - 1] for i in obs[0, 2::2])
            out.append(RolloutEpisode(ingredients, obs, actions[a:b, env].reshape(-1)))
    return out


class LogicTerm:
    """ℓ_logic of a policy on rollout episodes: the mean over (episode, ingredient) rows."""

    def __init__(self, kind: str, knowledge: CookingKnowledge) -> None:
        if kind not in ("tleaf", "exact", "checker"):
            raise SettingError("kind", f"{kind!r}: expected tleaf, exact or checker")
        self.kind = kind
        self.knowledge = knowledge

    def loss(self, policy, episodes: Sequence[RolloutEpisode]) -> torch.Tensor:
        """Differentiable ℓ_logic (tleaf, exact) of `policy` (an SB3 ActorCriticPolicy)."""
        if self.kind == "checker":
            return torch.tensor(self.violation_rate(episodes))
        log_policy = _policy_log_probs(policy, episodes)  # [E, T, A], one forward
        lengths = torch.tensor([len(e.actions) for e in episodes])
        # one row per (episode, ingredient): the episode against that ingredient's rule set
        index, rules = [], []
        for ingredients, members in _by_ingredients(episodes).items():
            trainable = self.knowledge.rules(ingredients).trainable
            for member in members:
                index += [member] * len(trainable)
                rules += trainable
        if not rules:
            return torch.zeros(())
        rows = torch.tensor(index)
        return logic_loss(  # each episode names its action ids after its own ingredients
            self.kind,
            log_policy[rows],
            rules,
            lengths[rows],
            self.knowledge.embedder,
            per_sequence_vocabulary=True,
        )

    def violation_rate(self, episodes: Sequence[RolloutEpisode]) -> float:
        """Share of (episode, ingredient) rows whose SAMPLED actions violate the rule set."""
        sets, sequences = [], []
        for e in episodes:
            for rule_set in self.knowledge.rules(e.ingredients).sets:
                if rule_set is not None:
                    sets.append(rule_set)
                    sequences.append(e.actions)
        return float(violates(sets, sequences).mean()) if sets else 0.0


def _by_ingredients(episodes: Sequence[RolloutEpisode]) -> dict[tuple[str, ...], list[int]]:
    """Episode indices grouped by ingredient set, in first-seen order."""
    groups: dict[tuple[str, ...], list[int]] = {}
    for i, e in enumerate(episodes):
        groups.setdefault(e.ingredients, []).append(i)
    return groups


def _policy_log_probs(policy, episodes: Sequence[RolloutEpisode]) -> torch.Tensor:
    """log π(·|s_t) at every step of every episode: [E, T_max, A], padded with log(1/A)."""
    steps = [len(e.actions) for e in episodes]
    obs = torch.as_tensor(np.concatenate([e.observations for e in episodes]), device=policy.device)
    logits = policy.get_distribution(obs.float()).distribution.logits
    padded = logits.new_zeros(len(episodes), max(steps), logits.shape[-1])
    mask = torch.arange(max(steps))[None, :] < torch.tensor(steps)[:, None]
    padded = padded.masked_scatter(mask[..., None], logits)
    return torch.log_softmax(padded, dim=-1)
