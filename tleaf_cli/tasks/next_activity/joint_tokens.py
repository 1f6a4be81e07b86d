"""Suffix prediction of events with attributes: an event is one **joint token**, its activity and
its value of each attribute the model predicts (`Encoder.attributes`), so the suffix search and
sampling (suffix_search.py, suffix_sampling.py) run over events unchanged.

- **Tokens.** Every combination: token = a · Π_k (R_k + 1) + the values in mixed radix (value
  index 0: none, or a value training never saw). Helpdesk's 14 activities and 22 resources give
  14 · 23 = 322 tokens; more than `MAX_TOKENS` is refused (predict fewer attributes).
- **Scores.** log p(a, v | prefix) = log p(a | prefix) + Σ_k log p(v_k | prefix, a), the model's
  activity output and attribute heads (attribute_heads.py) in one call per step; the end of the
  case is the activity output's end.
- **Rules.** A knowledge base may speak of attributes (MP-Declare: `Existence[Closed] |A.org:
  resource is not Value 3|` is `F(closed & org_resource__is_not__value_3)`, the condition one
  atom). A `.decl`'s activities read the run's atoms (matched to the log's names exactly). Each
  rule is compiled alone, as check-cases compiles it (case_checks.py: one-hot where it names
  activities only, else over the powerset of its own atoms), and token t reads, in rule k's DFA,
  the letter of its atoms: its activity's, "attribute is value" for each value it has, and each
  condition that holds on its values (`Case.letters`). The rules are the parts of one
  `RuleAutomaton`: a suffix keeps them when every rule accepts.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
import torch

from tleaf_cli.data.activity_names import attribute_atom
from tleaf_cli.data.cases import Case, EventTest
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.tasks.case_checks import compile_rules, read_case_rules
from tleaf_cli.tasks.next_activity.batch import CaseBatch
from tleaf_cli.tasks.next_activity.encoding import Encoder
from tleaf_cli.tasks.next_activity.lstm_calls import LSTMCalls
from tleaf_cli.tasks.next_activity.model import NextActivityLSTM
from tleaf_cli.tasks.next_activity.rule_automaton import RuleAutomaton
from tleaf_cli.tasks.next_activity.suffix_search import Rows

MAX_TOKENS = 20_000  # joint tokens a search may score per step and branch
CHUNK = 1024  # rows per model forward


@dataclass(frozen=True)
class JointTokens:
    """The joint tokens of an encoder's activities and attribute values (module docstring)."""

    encoder: Encoder

    def __post_init__(self) -> None:
        if self.size > MAX_TOKENS:
            raise SettingError(
                "attributes",
                f"{len(self.encoder.atoms)} activities × the values of "
                f"{', '.join(self.encoder.attributes)} make {self.size} events to choose from "
                f"(at most {MAX_TOKENS}): predict fewer attributes",
            )

    @property
    def per_activity(self) -> int:
        """Tokens per activity: Π_k (R_k + 1)."""
        return math.prod(self.encoder.value_counts)

    @property
    def size(self) -> int:
        return len(self.encoder.atoms) * self.per_activity

    def encode(self, activities: np.ndarray, values: np.ndarray) -> np.ndarray:
        """int64 [n]: the tokens of activities [n] with value indices [n, K]."""
        out = np.asarray(activities, dtype=np.int64) * self.per_activity
        radix = 1
        for k in reversed(range(len(self.encoder.attributes))):
            out = out + values[:, k] * radix
            radix *= self.encoder.value_counts[k]
        return out

    def decode(self, tokens: Sequence[int] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(activities [n], value indices [n, K]) of tokens [n]."""
        rest = np.asarray(tokens, dtype=np.int64)
        activities, rest = np.divmod(rest, self.per_activity)
        values = np.zeros((len(rest), len(self.encoder.attributes)), dtype=np.int64)
        for k in reversed(range(len(self.encoder.attributes))):
            rest, values[:, k] = np.divmod(rest, self.encoder.value_counts[k])
        return activities, values

    def of_case(self, case: Case) -> np.ndarray:
        """int64 [n]: the case's events as tokens; an event of an activity the model does not
        know is negative (`decode`: activity −1)."""
        activities = self.encoder.indices(case, unknown=-1)
        return self.encode(activities, self.encoder.value_indices(case))

    def letters(self, tests: Mapping[str, EventTest] | None = None) -> list[frozenset[str]]:
        """Per token, the atoms true at such an event: its activity's, "attribute is value" for
        each value it has, and each atom of `tests` that holds on its values."""
        activities, values = self.decode(np.arange(self.size))
        names = list(zip(self.encoder.attributes, self.encoder.values, strict=True))
        out = []
        for a, row in zip(activities.tolist(), values.tolist(), strict=True):
            event = {n: vs[i - 1] if i else None for (n, vs), i in zip(names, row, strict=True)}
            letter = [self.encoder.atoms[a]]
            letter += [attribute_atom(n, v) for n, v in event.items() if v is not None]
            letter += [atom for atom, test in (tests or {}).items() if test.holds(event)]
            out.append(frozenset(letter))
        return out


@dataclass(frozen=True)
class JointRules:
    """A knowledge base over joint tokens: its rules' names, the automaton the searches read,
    whether it names activities only, and the atoms it names that no token has (values
    training never saw, activities the model does not know)."""

    path: str
    names: tuple[str, ...]
    automaton: RuleAutomaton
    activities_only: bool
    unseen: tuple[str, ...]


def joint_rules(
    path: str | os.PathLike, tokens: JointTokens, names: Sequence[str] = ()
) -> JointRules:
    """The rules of `path` (all, or those named) over `tokens`; InputError naming the file and
    line of a rule that does not read or compile, or a name the file does not have."""
    rules = read_case_rules(path, tokens.encoder.names())
    if names:
        by_name = {r.name: r for r in rules}
        unknown = [n for n in names if n not in by_name]
        if unknown:
            raise InputError(f"{path}: no rule named {', '.join(unknown)}")
        rules = [by_name[n] for n in names]
    activities_only = all(r.one_hot for r in rules)
    tests = {atom: test for r in rules for atom, test in r.conditions.items()}
    unread = sorted(
        {a for t in tests.values() for a in t.attributes} - set(tokens.encoder.attributes)
    )
    if unread:
        raise InputError(
            f"{path}: a condition reads the event attribute {unread[0]!r}, which the run does not "
            f"predict (it predicts: {', '.join(tokens.encoder.attributes) or 'none'}): train "
            "a model that predicts it, or leave such rules out"
        )
    dfas = compile_rules(rules)
    letters = tokens.letters(tests)
    known = set().union(*letters)
    columns = [np.array([d.alphabet.index(ls) for ls in letters], dtype=np.int64) for d in dfas]
    unseen = sorted({a for r in rules for a in r.atoms if a not in known})
    return JointRules(
        os.fspath(path),
        tuple(r.name for r in rules),
        RuleAutomaton.of_letters(dfas, columns),
        activities_only,
        tuple(unseen),
    )


def joint_log_probs(
    model,
    encoder: Encoder,
    tokens: JointTokens,
    stamps: Sequence[Sequence],
    inputs: Sequence[np.ndarray] | None = None,
) -> Callable[[Rows], np.ndarray]:
    """The suffix search's model over the tokens: log-probabilities [N, tokens + 1] of the
    event after each row (the last column: the end of the case), a row's times and input
    columns those of its prefix (`stamps[owner]`, `inputs[owner]`), the appended events'
    placed by the encoder. Without attributes any next-activity model (the prefix table too)
    serves. An LSTM in eval mode advances each row of the call before by one event
    (lstm_calls.py) instead of rereading it: the same answer, O(1) per row and step."""
    device = torch.device("cpu")
    scores = partial(_state_scores, model, len(encoder.atoms))
    if isinstance(model, NextActivityLSTM) and not model.training:
        return LSTMCalls(model, encoder, tokens, stamps, inputs, scores)

    def call(rows: Rows) -> np.ndarray:
        out = []
        with torch.no_grad():
            for i in range(0, len(rows), CHUNK):
                part = rows[i : i + CHUNK]
                owners = rows.owners[i : i + CHUNK]
                decoded = [tokens.decode(row) for row in part]
                batch = CaseBatch.of_sequences(
                    [a for a, _ in decoded],
                    [stamps[o] for o in owners],
                    encoder,
                    device,
                    values=[vs for _, vs in decoded],
                    inputs=None if inputs is None else [inputs[o] for o in owners],
                )
                rows_at = torch.arange(len(part)), batch.lengths - 1
                if not encoder.attributes:  # the tokens are the activities (any model)
                    logits = batch.logits(model)[rows_at]
                    out.append(torch.log_softmax(logits.double(), dim=-1).numpy())
                    continue
                h = model.states(batch.activities, batch.times, batch.lengths, batch.attributes)
                out.append(scores(h[rows_at], len(part)))
        return np.concatenate(out)

    return call


def _state_scores(model, v: int, last: torch.Tensor, n: int) -> np.ndarray:
    """float64 [n, tokens + 1]: the joint log-probabilities of the next event (activity, then
    each predicted attribute's value given the activity) and of the end, from the model's state
    after each of n rows (`last` [n, hidden])."""
    activity = torch.log_softmax(model.out(last).double(), dim=-1)
    joint = activity[:, :v]
    for values in model.heads.every(last):  # [N, V, R_k + 1]
        joint = joint[..., None] + values.double().reshape(n, v, *([1] * (joint.dim() - 2)), -1)
    flat = joint.reshape(n, -1)
    return torch.cat([flat, activity[:, v:]], dim=1).numpy()
