"""Predictions for running cases (`tleaf predict`): a trained next-activity run asked, for each
case still open (a prefix of events), what happens next, how the case goes on, whether each rule
of a knowledge base will hold when it ends, and which continuation would keep every rule.

Per prefix (`Predictor.predict`, a batch of prefixes at once, so a stream can call it per event):

- **the next event**: the top-k activities by the model's activity marginal (over the attribute
  values where the run predicts attributes: joint tokens, joint_tokens.py), the probability
  that the case ends now, and for the top activity the most probable value of each predicted
  attribute, p(value | prefix, activity);
- **the rest of the case** by argmax, beam search, a draw or minimum Bayes risk over draws
  (suffix_mbr.py; `PredictSettings.way`), the rules
  out of it, a hard filter or a soft score (`suffix_rules`), with its log-probability;
- **per rule**: its RV-LTL verdict now (`logic/verdicts.py`: the state its own DFA is in after
  the prefix's events, read as `Case.letters` gives them, MP-Declare conditions included), and
  the probability that it holds when the case ends: exact (0 or 1) where the verdict is
  permanent, else the share of `samples` completions drawn from the model at temperature 1
  (up to `max_suffix` events, where a completion stops: counted in `samples_at_cap`) whose
  completed case the rule accepts, with a 95 % Wilson interval;
- **a recommendation**: where the most probable completion (beam search without rules) breaks
  some rule, the most probable completion that keeps every rule (the same beam search under the
  rules as a hard filter) and its probability relative to the unconstrained one.

A prefix with an activity the run never saw gets no prediction (its `reason` says why) but its
verdicts; the others are predicted. predictions.py writes the `predictions` artifact.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from tleaf_cli.data.cases import Case
from tleaf_cli.errors import InputError
from tleaf_cli.logic.verdicts import Verdict
from tleaf_cli.settings.next_activity import PredictSettings
from tleaf_cli.tasks.next_activity.encoding import Encoder
from tleaf_cli.tasks.next_activity.evaluate import load_run
from tleaf_cli.tasks.next_activity.joint_tokens import JointTokens, joint_log_probs
from tleaf_cli.tasks.next_activity.monitoring import (
    MonitoredRules,
    monitored_rules,
    sample_holds,
    shared,
    wilson,
)
from tleaf_cli.tasks.next_activity.suffix_mbr import mbr_suffixes
from tleaf_cli.tasks.next_activity.suffix_sampling import sample_suffixes
from tleaf_cli.tasks.next_activity.suffix_search import NextLogProbs, Rows, predict_suffixes
from tleaf_cli.training.run_folder import read_run_config, recorded_input


@dataclass(frozen=True)
class RuleForecast:
    """One rule on one running case: its verdict now and its probability of holding when the
    case ends (`method`: "exact" for a permanent verdict, "sampled", or None: not estimated)."""

    rule: str
    verdict: str
    probability: float | None
    low: float | None
    high: float | None
    method: str | None


@dataclass(frozen=True)
class Prediction:
    """What a predictor says about one running case (module docstring); every prediction field
    None (empty for lists) where `reason` says why the case could not be predicted."""

    case_id: str
    prefix_length: int
    reason: str | None
    next_activities: tuple[tuple[str, float], ...]  # (activity, probability), best first
    end_probability: float | None
    next_attributes: tuple[tuple[str, str | None, float], ...]  # (attribute, value, p)
    suffix: tuple[str, ...] | None  # activities
    suffix_values: tuple[tuple[str | None, ...], ...] | None  # per event, per attribute
    suffix_log_prob: float | None
    suffix_found: bool | None  # with the rules a filter: a continuation keeping them found
    rules: tuple[RuleForecast, ...]
    samples_at_cap: int | None  # sampled completions that reached max_suffix events
    recommendation_status: str | None  # None without rules; "not needed", "found", "none"
    recommendation: tuple[str, ...] | None
    recommendation_values: tuple[tuple[str | None, ...], ...] | None
    recommendation_log_prob: float | None
    recommendation_relative: float | None  # exp(its log-prob − the unconstrained one's)


class Predictor:
    """A next-activity run and the rules it watches, answering for batches of running cases."""

    def __init__(
        self,
        model,
        encoder: Encoder,
        settings: PredictSettings | None = None,
        rules: MonitoredRules | None = None,
    ) -> None:
        self.model = model
        self.encoder = encoder
        self.settings = settings or PredictSettings()
        self.settings.check()
        self.tokens = JointTokens(encoder)
        self.rules = rules

    @classmethod
    def load(
        cls,
        run_dir: str | os.PathLike,
        settings: PredictSettings | None = None,
        rules_path: str | os.PathLike | None = None,
        rule_names: Sequence[str] = (),
    ) -> Predictor:
        """The run's model and the rules of `rules_path` (default: the knowledge base the run
        trained with, from its config.json; none if it had none); InputError naming the folder
        that is not a next-activity run, or the rule file's problem."""
        config = read_run_config(run_dir, "next-activity")
        model, encoder, _ = load_run(run_dir)
        if rules_path is None:
            rules_path = recorded_input(run_dir, config, "kb")
            if rules_path is None and rule_names:
                raise InputError(f"{run_dir}: trained without rules; name a rule file to watch")
        rules = None
        if rules_path is not None:
            rules = monitored_rules(rules_path, JointTokens(encoder), rule_names)
        return cls(model, encoder, settings, rules)

    @property
    def rule_names(self) -> tuple[str, ...]:
        return () if self.rules is None else self.rules.names

    def predict(self, prefixes: Sequence[Case]) -> list[Prediction]:
        """One `Prediction` per running case (its events so far), in order."""
        sequences = [self.tokens.of_case(c) for c in prefixes]
        readable = [len(s) > 0 and bool((s >= 0).all()) for s in sequences]
        ok = [i for i, r in enumerate(readable) if r]
        starts = (
            np.stack([self.rules.states(c) for c in prefixes])
            if self.rules is not None and len(prefixes)
            else np.zeros((len(prefixes), 0), dtype=np.int64)
        )
        answers: dict[int, dict] = {}
        if ok:
            found = self._predict(
                [prefixes[i] for i in ok],
                [tuple(sequences[i].tolist()) for i in ok],
                starts[ok],
            )
            answers = dict(zip(ok, found, strict=True))
        out = []
        for i, case in enumerate(prefixes):
            verdicts = self._verdicts(starts[i])
            if i in answers:
                out.append(Prediction(case.case_id, len(case), None, **answers[i]))
                continue
            unknown = sorted({n for n, a in zip(case.activities, case.atoms, strict=True)
                              if a not in self.encoder.atoms})  # fmt: skip
            reason = (
                "no events"
                if not len(case)
                else f"activity {unknown[0]!r} was never seen in training"
                + (f" (and {len(unknown) - 1} more)" if len(unknown) > 1 else "")
            )
            out.append(_unpredicted(case, reason, verdicts))
        return out

    def _verdicts(self, states: np.ndarray) -> list[tuple[str, Verdict]]:
        if self.rules is None:
            return []
        return [
            (name, Verdict(int(v[s])))
            for name, v, s in zip(self.rules.names, self.rules.verdicts, states, strict=True)
        ]

    def _predict(
        self, cases: list[Case], prefixes: list[tuple[int, ...]], starts: np.ndarray
    ) -> list[dict]:
        s, encoder, tokens = self.settings, self.encoder, self.tokens
        n, size = len(cases), tokens.size
        step = joint_log_probs(
            self.model,
            encoder,
            tokens,
            [c.timestamps for c in cases],
            [encoder.input_columns(c) for c in cases],
        )
        first = np.asarray(step(Rows(list(prefixes), list(range(n)))), dtype=np.float64)
        v, per = len(encoder.atoms), tokens.per_activity
        joint = np.exp(first[:, :-1]).reshape(n, v, per)
        activity = joint.sum(axis=2)
        order = np.argsort(-activity, axis=1, kind="stable")[:, : min(s.top_k, v)]
        automaton = None if self.rules is None else self.rules.automaton
        ruled = automaton if s.suffix_rules != "none" else None
        weight = s.rule_weight if s.suffix_rules == "soft" else None
        if s.way == "sample":
            suffixes = sample_suffixes(
                step, prefixes, size, rules=ruled, temperature=s.temperature,
                max_length=s.max_suffix, seed=s.seed, rule_weight=weight,
            )  # fmt: skip
        elif s.way == "mbr":
            suffixes = mbr_suffixes(
                step, prefixes, size, rules=ruled, samples=s.mbr_samples,
                max_length=s.max_suffix, seed=s.seed, rule_weight=weight,
                compared=lambda t: tokens.decode(t)[0],
            )  # fmt: skip
        else:
            width = 1 if s.way == "argmax" else s.beam_width
            suffixes = predict_suffixes(
                step, prefixes, size, rules=ruled, beam_width=width,
                max_length=s.max_suffix, rule_weight=weight,
            )  # fmt: skip
        forecasts = self._forecasts(step, prefixes, starts)
        recommended = self._recommend(step, prefixes, suffixes, forecasts)
        out = []
        for i in range(n):
            top = int(order[i, 0])
            out.append(
                {
                    "next_activities": tuple(
                        (encoder.activities[a], float(activity[i, a])) for a in order[i].tolist()
                    ),
                    "end_probability": float(np.exp(first[i, -1])),
                    "next_attributes": self._attributes(joint[i, top]),
                    "suffix": self._names(suffixes[i].activities),
                    "suffix_values": self._values(suffixes[i].activities),
                    "suffix_log_prob": float(suffixes[i].log_prob),
                    "suffix_found": suffixes[i].found if s.suffix_rules == "filter" else None,
                    **forecasts[i],
                    **recommended[i],
                }
            )
        return out

    def _attributes(self, block: np.ndarray) -> tuple[tuple[str, str | None, float], ...]:
        """Per predicted attribute, its most probable value for one activity and p(value |
        prefix, activity), from the activity's joint tokens' probabilities."""
        counts = self.encoder.value_counts
        if not counts:
            return ()
        cube = (block / max(block.sum(), 1e-300)).reshape(counts)
        out = []
        for k, (name, values) in enumerate(
            zip(self.encoder.attributes, self.encoder.values, strict=True)
        ):
            marginal = cube.sum(axis=tuple(j for j in range(len(counts)) if j != k))
            j = int(np.argmax(marginal))
            out.append((name, values[j - 1] if j else None, float(marginal[j])))
        return tuple(out)

    def _names(self, tokens: Sequence[int]) -> tuple[str, ...]:
        activities, _ = self.tokens.decode(list(tokens))
        return tuple(self.encoder.activities[a] for a in activities.tolist())

    def _values(self, tokens: Sequence[int]) -> tuple[tuple[str | None, ...], ...]:
        if not self.encoder.attributes:
            return ()
        _, values = self.tokens.decode(list(tokens))
        return tuple(
            tuple(vs[j - 1] if j else None for vs, j in zip(self.encoder.values, row, strict=True))
            for row in values.tolist()
        )

    def _forecasts(
        self, step: NextLogProbs, prefixes: list[tuple[int, ...]], starts: np.ndarray
    ) -> list[dict]:
        """Per prefix, each rule's verdict and probability of holding at the end."""
        n, s = len(prefixes), self.settings
        if self.rules is None:
            return [{"rules": (), "samples_at_cap": None} for _ in range(n)]
        draws = s.samples
        if draws:
            kept, at_cap = sample_holds(
                step, prefixes, starts, self.rules, self.tokens.size, draws, s.max_suffix, s.seed
            )
            low, high = wilson(kept, draws)
        out = []
        for i in range(n):
            rules = []
            for k, (name, verdict) in enumerate(self._verdicts(starts[i])):
                if verdict.final:
                    p = 1.0 if verdict.satisfied else 0.0
                    rules.append(RuleForecast(name, str(verdict), p, p, p, "exact"))
                elif draws:
                    p = float(kept[i, k] / draws)
                    low_, high_ = float(low[i, k]), float(high[i, k])
                    rules.append(RuleForecast(name, str(verdict), p, low_, high_, "sampled"))
                else:
                    rules.append(RuleForecast(name, str(verdict), None, None, None, None))
            out.append({"rules": tuple(rules), "samples_at_cap": int(at_cap[i]) if draws else None})
        return out

    def _recommend(
        self, step: NextLogProbs, prefixes: list[tuple[int, ...]], suffixes, forecasts
    ) -> list[dict]:
        """Per prefix, the best completion that keeps every rule where the most probable one
        (beam search, no rules) breaks some."""
        n, s = len(prefixes), self.settings
        empty = {
            "recommendation_status": None,
            "recommendation": None,
            "recommendation_values": None,
            "recommendation_log_prob": None,
            "recommendation_relative": None,
        }
        if self.rules is None:
            return [dict(empty) for _ in range(n)]
        automaton = self.rules.automaton
        free = suffixes
        if not (s.way == "beam" and s.suffix_rules == "none"):
            free = predict_suffixes(
                step, prefixes, self.tokens.size, beam_width=s.beam_width, max_length=s.max_suffix
            )
        broken = [i for i in range(n) if not automaton.accepts(prefixes[i] + free[i].activities)]
        out = [dict(empty, recommendation_status="not needed") for _ in range(n)]
        if not broken:
            return out
        kept = predict_suffixes(
            shared(step, broken), [prefixes[i] for i in broken], self.tokens.size,
            rules=automaton, beam_width=s.beam_width, max_length=s.max_suffix,
        )  # fmt: skip
        for i, found in zip(broken, kept, strict=True):
            if not found.found:
                out[i]["recommendation_status"] = "none"
                continue
            out[i] = {
                "recommendation_status": "found",
                "recommendation": self._names(found.activities),
                "recommendation_values": self._values(found.activities),
                "recommendation_log_prob": float(found.log_prob),
                "recommendation_relative": float(math.exp(found.log_prob - free[i].log_prob)),
            }
        return out


def _unpredicted(case: Case, reason: str, verdicts: list[tuple[str, Verdict]]) -> Prediction:
    """A prediction that could not be made (`reason`), with the rules' verdicts only."""
    rules = []
    for name, verdict in verdicts:
        p = (1.0 if verdict.satisfied else 0.0) if verdict.final else None
        method = "exact" if verdict.final else None
        rules.append(RuleForecast(name, str(verdict), p, p, p, method))
    return Prediction(
        case.case_id, len(case), reason, (), None, (), None, None, None, None, tuple(rules),
        None, None, None, None, None, None,
    )  # fmt: skip


def cut(case: Case, k: int) -> Case:
    """The case as it was after its first k events (a running case)."""
    return replace(
        case,
        activities=case.activities[:k],
        atoms=case.atoms[:k],
        timestamps=case.timestamps[:k],
        attributes={name: values[:k] for name, values in case.attributes.items()},
    )
