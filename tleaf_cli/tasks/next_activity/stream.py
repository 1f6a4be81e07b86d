"""The live stream of `tleaf predict RUN --follow`: events of running cases arrive one at a time
(JSON lines), and each gets its case's updated prediction at once (docs/monitoring.md, "Live
stream").

`StreamMonitor.feed(event)` takes one event — `{"case": ..., "activity": ..., "timestamp":
ISO 8601, "attributes": {...}, "end": bool}` — and returns the output line's content: the
fields of the `predictions` artifact's row (predictions.py), for the case as it stands after
the event. What it keeps per open case (`OpenCase`):

- each rule's DFA state, advanced by the event's letter alone (the prefix is never re-run):
  one table lookup per rule, all rules at once (`_Tables`), the verdict read off the state;
- the case's events so far (activities, atoms, times, attribute values), which the model reads;
- for an LSTM (`NextActivityLSTM`), its hidden and cell state after the last event, so the next
  event costs one LSTM step (`LSTMStep`, lstm_step.py: the model's weights stepped in numpy;
  the new event's features read off it, the one before it and the case's first); any other
  model (the transformer, the prefix table) re-reads the whole prefix at each event, as the
  batch predictor does. The rule probabilities
  (`samples` > 0) and the suffix and recommendation (`suffix=True`) re-read the prefix too:
  they are `Predictor`'s, on the case as it stands.

An event whose activity the run never saw is not skipped: the case goes on, its verdicts
updated (the event's letter is its own atom: a rule naming that activity reads it, the others
read another activity), but the model cannot read the prefix any more, so from that event on the
case's prediction is null with its `reason` — as a batch row of such a prefix. An end mark
(`"end": true`, with an event or alone) closes the case: the line gives its final verdicts (the
case ended, so a temporarily satisfied rule is permanently satisfied, a temporarily violated
one permanently violated), the case is dropped, and a later event for it is refused (for the
last `StreamMonitor.closed_memory` ended cases: the memory of a stream that runs for months stays
bounded).

A bad event raises a `BadEvent` (stream_events.py: the protocol, its reasons, the loop that
reports and counts them) and changes nothing.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from datetime import datetime

import numpy as np
import torch

from tleaf_cli.data.activity_names import attribute_atom, bind_atoms
from tleaf_cli.data.cases import Case
from tleaf_cli.logic.verdicts import Verdict
from tleaf_cli.tasks.next_activity.joint_tokens import joint_log_probs
from tleaf_cli.tasks.next_activity.lstm_step import LSTMStep
from tleaf_cli.tasks.next_activity.model import NextActivityLSTM
from tleaf_cli.tasks.next_activity.monitoring import MonitoredRules, sample_holds, wilson
from tleaf_cli.tasks.next_activity.predict import Predictor
from tleaf_cli.tasks.next_activity.stream_events import (
    CASE_SCOPE,
    CLOSED,
    ENDED,
    MALFORMED,
    NOT_OPEN,
    OUT_OF_ORDER,
    BadEvent,
    event_fields,
    first_line,
)
from tleaf_cli.tasks.next_activity.suffix_search import Rows

_LETTER_CACHE = 1 << 16  # distinct event letters whose columns are kept
_attribute_atom = functools.lru_cache(maxsize=1 << 16)(attribute_atom)  # values repeat


@dataclass
class OpenCase:
    """What the monitor keeps of a case still running (module docstring)."""

    case_id: str
    states: np.ndarray  # int64 [R]: each rule's DFA state after the events so far
    activities: list[str] = field(default_factory=list)
    atoms: list[str] = field(default_factory=list)
    timestamps: list[datetime] = field(default_factory=list)
    attributes: dict[str, list[str | None]] = field(default_factory=dict)  # per event
    case_attributes: dict[str, str | None] = field(default_factory=dict)
    indices: list[int] = field(default_factory=list)  # the model's activity indices
    tokens: list[int] = field(default_factory=list)  # the model's (joint) tokens
    unknown: list[str] = field(default_factory=list)  # activities the run never saw
    memory: tuple[np.ndarray, np.ndarray] | None = None  # the LSTM's (h, c) [layers, H]

    def __len__(self) -> int:
        return len(self.activities)

    def case(self) -> Case:
        """The case so far, as the batch predictor reads one."""
        return Case(
            self.case_id,
            tuple(self.activities),
            tuple(self.atoms),
            tuple(self.timestamps),
            "stream",
            attributes={name: tuple(values) for name, values in self.attributes.items()},
            case_attributes=dict(self.case_attributes),
        )


class _Tables:
    """Every rule's DFA as one flat table, so that one event advances all rules in one numpy
    lookup: rule k's state s on letter column c is `flat[base[k] + s * width[k] + c]`."""

    def __init__(self, rules: MonitoredRules | None) -> None:
        dfas = () if rules is None else rules.dfas
        self.dfas = dfas
        self.initial = np.array([d.initial for d in dfas], dtype=np.int64)
        width = np.array([d.table.shape[1] for d in dfas], dtype=np.int64)
        sizes = np.array([d.table.size for d in dfas], dtype=np.int64)
        states = np.array([d.num_states for d in dfas], dtype=np.int64)
        self.width = width
        self.base = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        self.flat = (
            np.concatenate([d.table.ravel() for d in dfas]).astype(np.int64)
            if dfas
            else np.zeros(0, dtype=np.int64)
        )
        self.state_base = np.concatenate([[0], np.cumsum(states)[:-1]]).astype(np.int64)
        self.per_rule = () if rules is None else rules.verdicts
        self.accepting = (
            np.concatenate([d.accepting for d in dfas]) if dfas else np.zeros(0, dtype=bool)
        )
        self._columns: dict[frozenset[str], np.ndarray] = {}

    def step(self, states: np.ndarray, letter: frozenset[str]) -> np.ndarray:
        """Each rule's state after `letter` from `states` [R]."""
        columns = self._columns.get(letter)
        if columns is None:
            if len(self._columns) >= _LETTER_CACHE:
                self._columns.clear()
            columns = np.array([d.alphabet.index(letter) for d in self.dfas], dtype=np.int64)
            self._columns[letter] = columns
        return self.flat[self.base + states * self.width + columns]

    def accepts(self, states: np.ndarray) -> np.ndarray:
        return self.accepting[self.state_base + states]


class StreamMonitor:
    """The open cases of a stream and what a run says about each after every event (module
    docstring). `predictor.settings` give top-k, samples, max-suffix, seed and the suffix's
    way; `suffix`: also the predicted rest of the case and the recommendation (they cost a
    search per event). The ids of the last `closed_memory` ended cases are remembered, to refuse
    their later events; an event for a case that ended before them opens a new case."""

    closed_memory = 100_000  # ended case ids remembered: ~10 MB

    def __init__(self, predictor: Predictor, suffix: bool = False) -> None:
        self.predictor = predictor
        self.settings = predictor.settings
        self.suffix = suffix
        self.encoder = predictor.encoder
        self.tokens = predictor.tokens
        self.rules = predictor.rules
        self.model = predictor.model
        self.lstm = isinstance(self.model, NextActivityLSTM)
        self.cell = LSTMStep(self.model) if self.lstm else None
        self.tables = _Tables(self.rules)
        self.names = self.encoder.names()  # activity name -> atom, as the run's log maps them
        self.index = {a: i for i, a in enumerate(self.encoder.atoms)}
        self.value_index = [{v: i + 1 for i, v in enumerate(vs)} for vs in self.encoder.values]
        self.event_inputs = [i.attribute for i in self.encoder.inputs if not i.of_case]
        self.case_inputs = [i.attribute for i in self.encoder.inputs if i.of_case]
        self.tests = {} if self.rules is None else dict(self.rules.tests)
        self._rows, self._final = [], []  # per rule and state (`_Tables.state_base`)
        for name, verdicts in zip(self.rule_names, self.tables.per_rule, strict=True):
            for code in verdicts.tolist():
                verdict = Verdict(code)
                p = (1.0 if verdict.satisfied else 0.0) if verdict.final else None
                method = "exact" if verdict.final else None
                self._rows.append(_rule(name, verdict, p, p, p, method))
                self._final.append(verdict.final)
        self._ends = [  # per rule: its line where the case ends in a rejecting, accepting state
            (
                _rule(name, Verdict.PERMANENTLY_VIOLATED, 0.0, 0.0, 0.0, "exact"),
                _rule(name, Verdict.PERMANENTLY_SATISFIED, 1.0, 1.0, 1.0, "exact"),
            )
            for name in self.rule_names
        ]
        self._unknown_atoms: dict[str, str] = {}
        self._suffixes = (
            Predictor(self.model, self.encoder, replace(self.settings, samples=0), self.rules)
            if suffix
            else None
        )
        self.open: dict[str, OpenCase] = {}
        self.closed: dict[str, None] = {}  # the ended cases' ids, oldest first

    @property
    def rule_names(self) -> tuple[str, ...]:
        return self.predictor.rule_names

    def knows(self, activity: str | None) -> bool:
        """Whether the run saw this activity in training (None: an end mark alone)."""
        return activity is None or activity in self.names

    # ---------------------------------------------------------------- input
    def feed_line(self, text: str | bytes, line: int | None = None) -> dict:
        """`feed` of one JSON line; BadEvent (MALFORMED) for text that is no JSON object."""
        try:
            if isinstance(text, bytes):
                text = text.decode("utf-8")
            event = json.loads(text)
        except (UnicodeDecodeError, json.JSONDecodeError) as e:
            raise BadEvent(MALFORMED, f"not a JSON line ({first_line(e)})") from None
        if not isinstance(event, dict):
            raise BadEvent(MALFORMED, f"a JSON {type(event).__name__}, not an object")
        return self.feed(event, line)

    def feed(self, event: Mapping, line: int | None = None) -> dict:
        """The output line's content after `event` (module docstring; `line`: the input line's
        number, echoed); BadEvent, nothing changed, for an event that cannot be taken."""
        case_id, activity, stamp, attributes, end = event_fields(event)
        if case_id in self.closed:
            raise BadEvent(CLOSED, f"case {case_id!r} already ended (an end mark came before)")
        opened = self.open.get(case_id)
        if activity is None:  # an end mark alone
            if opened is None:
                raise BadEvent(NOT_OPEN, f"end mark for case {case_id!r}, which has no events")
            return self._close(opened, line, None)
        if opened is not None and opened.timestamps and stamp < opened.timestamps[-1]:
            raise BadEvent(
                OUT_OF_ORDER,
                f"case {case_id!r}: timestamp {stamp.isoformat()} is before its previous "
                f"event's, {opened.timestamps[-1].isoformat()}",
            )
        if opened is None:
            opened = self.open[case_id] = OpenCase(case_id, self.tables.initial.copy())
        self._append(opened, activity, stamp, attributes)
        if end:
            return self._close(opened, line, activity)
        return self._predict(opened, line, activity)

    # ---------------------------------------------------------------- state
    def _atom(self, activity: str) -> str:
        atom = self.names.get(activity)
        if atom is None:
            atom = self._unknown_atoms.get(activity)
            if atom is None:  # an atom of its own, as a rule file naming it would bind it
                atom = self._unknown_atoms[activity] = bind_atoms([activity], self.names)[activity]
        return atom

    def _append(
        self, case: OpenCase, activity: str, stamp: datetime, attributes: dict[str, str | None]
    ) -> None:
        """The event added to the case: its letter advances every rule, and the model reads
        it (one LSTM step) while the case has no activity the run never saw."""
        n = len(case)
        atom = self._atom(activity)
        values = {}
        for name, value in attributes.items():
            if name.startswith(CASE_SCOPE):
                case.case_attributes.setdefault(name[len(CASE_SCOPE) :], value)
            else:
                values[name] = value
        for name in [*values, *self.encoder.attributes, *self.event_inputs]:
            if name not in case.attributes:
                case.attributes[name] = [None] * n
        for name, column in case.attributes.items():
            column.append(values.get(name))
        for name in self.case_inputs:
            case.case_attributes.setdefault(name, None)
        case.activities.append(activity)
        case.atoms.append(atom)
        case.timestamps.append(stamp)
        letter = [atom] + [_attribute_atom(k, v) for k, v in values.items() if v is not None]
        if self.tests:
            letter += [a for a, test in self.tests.items() if test.holds(values)]
        if len(self.tables.dfas):
            case.states = self.tables.step(case.states, frozenset(letter))
        if activity not in self.names:
            if activity not in case.unknown:
                case.unknown.append(activity)
            case.memory = None
            return
        if case.unknown:
            return
        a = self.index[atom]
        pairs = zip(self.value_index, self.encoder.attributes, strict=True)
        row = np.array([m.get(values.get(name), 0) for m, name in pairs], dtype=np.int64)
        row = row.reshape(1, len(self.encoder.attributes))
        case.indices.append(a)
        case.tokens.append(int(self.tokens.encode(np.array([a]), row)[0]))
        if self.lstm:
            case.memory = self._lstm_step(case, a, row)

    def _feature_row(self, case: OpenCase) -> np.ndarray:
        """float32 [F]: the last event's features (time and inputs), as the batch's row for it.
        Each row reads only its own event, the one before it and the case's first, so the
        encoder is given those three and the position (the first time feature) set to n: the
        cost does not grow with the case."""
        n = len(case.indices)
        window = sorted({0, max(n - 2, 0), n - 1})
        times = [case.timestamps[i] for i in window]
        inputs = None
        if self.encoder.inputs:
            part = Case(
                case.case_id,
                tuple(case.activities[i] for i in window),
                tuple(case.atoms[i] for i in window),
                tuple(times),
                "stream",
                attributes={k: tuple(v[i] for i in window) for k, v in case.attributes.items()},
                case_attributes=dict(case.case_attributes),
            )
            inputs = self.encoder.input_columns(part)
        row = self.encoder.features([case.indices[i] for i in window], times, inputs)[-1]
        row[0] = n / max(self.encoder.mean_length, 1e-9)
        return row

    def _lstm_step(self, case: OpenCase, a: int, values: np.ndarray):
        """The LSTM's (h, c) after the case's last event (`a`, its value indices), from its
        state before it: `NextActivityLSTM.states` one step at a time (`_Cell`)."""
        x = np.zeros(self.cell.inputs, dtype=np.float32)
        x[a] = 1.0
        features = self._feature_row(case)
        v = len(self.encoder.atoms)
        x[v : v + len(features)] = features
        for k, embedding in enumerate(self.cell.embeddings):
            x[v + len(features) :] += embedding[max(int(values[0, k]), 0)]
        return self.cell.step(x, case.memory)

    def _first(self, case: OpenCase) -> np.ndarray:
        """float64 [tokens + 1]: log p(next event | the case so far), the end last; as
        `joint_log_probs` gives it."""
        if not self.lstm:
            step = self._step(case)
            return np.asarray(step(Rows([tuple(case.tokens)], [0])), dtype=np.float64)[0]
        model, v = self.model, len(self.encoder.atoms)
        top = case.memory[0][-1]  # [hidden]: the top layer's output after the event
        logits = (self.cell.out_weight @ top + self.cell.out_bias).astype(np.float64)
        activity = logits - _logsumexp(logits)
        if not self.encoder.attributes:
            return activity
        with torch.no_grad():
            last = torch.from_numpy(top)[None]
            joint = torch.from_numpy(activity[None, :v])
            for values in model.heads.every(last):  # [1, V, R_k + 1]
                joint = joint[..., None] + values.double().reshape(
                    1, v, *([1] * (joint.dim() - 2)), -1
                )
            return np.concatenate([joint.reshape(-1).numpy(), activity[v:]])

    def _step(self, case: OpenCase):
        inputs = [self.encoder.input_columns(case.case())] if self.encoder.inputs else None
        return joint_log_probs(
            self.model, self.encoder, self.tokens, [tuple(case.timestamps)], inputs
        )

    # ---------------------------------------------------------------- output
    def _head(self, case: OpenCase, line: int | None, activity: str | None, ended: bool) -> dict:
        return {
            "line": line,
            "case_id": case.case_id,
            "activity": activity,
            "timestamp": case.timestamps[-1].isoformat().replace("+00:00", "Z"),
            "prefix_length": len(case),
            "ended": ended,
        }

    def _predict(self, case: OpenCase, line: int | None, activity: str) -> dict:
        s, encoder = self.settings, self.encoder
        out = self._head(case, line, activity, False)
        at = (self.tables.state_base + case.states).tolist()
        rules = [dict(self._rows[i]) for i in at]  # the verdict now; exact where permanent
        undecided = [k for k, i in enumerate(at) if not self._final[i]]
        predicted = not case.unknown
        if not predicted:
            out["reason"] = f"activity {case.unknown[0]!r} was never seen in training" + (
                f" (and {len(case.unknown) - 1} more)" if len(case.unknown) > 1 else ""
            )
            out |= {"next_activities": [], "end_probability": None, "next_attributes": []}
        else:
            first = self._first(case)
            v, per = len(encoder.atoms), self.tokens.per_activity
            joint = np.exp(first[:-1]).reshape(v, per)
            marginal = joint.sum(axis=1)
            order = np.argsort(-marginal, kind="stable")[: min(s.top_k, v)]
            out["reason"] = None
            out["next_activities"] = [
                {"activity": encoder.activities[a], "probability": float(marginal[a])}
                for a in order.tolist()
            ]
            out["end_probability"] = float(np.exp(first[-1]))
            out["next_attributes"] = [
                {"attribute": name, "value": value, "probability": p}
                for name, value, p in self.predictor._attributes(joint[int(order[0])])
            ]
        out["rules"] = rules
        out["samples_at_cap"] = None
        if predicted and s.samples and undecided:
            kept, at_cap = sample_holds(
                self._step(case), [tuple(case.tokens)], case.states[None], self.rules,
                self.tokens.size, s.samples, s.max_suffix, s.seed,
            )  # fmt: skip
            low, high = wilson(kept, s.samples)
            for k in undecided:
                rules[k] |= {
                    "probability": float(kept[0, k] / s.samples),
                    "low": float(low[0, k]),
                    "high": float(high[0, k]),
                    "method": "sampled",
                }
            out["samples_at_cap"] = int(at_cap[0])
        if self.suffix:
            out |= self._suffix(case, predicted)
        return out

    def _suffix(self, case: OpenCase, predicted: bool) -> dict:
        fields = (
            "suffix", "suffix_values", "suffix_log_prob", "suffix_found", "recommendation_status",
            "recommendation", "recommendation_values", "recommendation_log_prob",
            "recommendation_relative",
        )  # fmt: skip
        if not predicted:
            return dict.fromkeys(fields)
        (p,) = self._suffixes.predict([case.case()])
        return {name: _plain(getattr(p, name)) for name in fields}

    def _close(self, case: OpenCase, line: int | None, activity: str | None) -> dict:
        """The case's last line: its final verdicts (a rule holds iff its DFA accepts now);
        the case dropped, its id remembered as ended."""
        out = self._head(case, line, activity, True)
        out |= {"reason": ENDED, "next_activities": [], "end_probability": None}
        out["next_attributes"] = []
        accepts = self.tables.accepts(case.states).tolist()
        out["rules"] = [dict(self._ends[k][a]) for k, a in enumerate(accepts)]
        out["samples_at_cap"] = None
        if self.suffix:
            out |= self._suffix(case, False)
        del self.open[case.case_id]
        self.closed[case.case_id] = None
        if len(self.closed) > self.closed_memory:  # a stream runs for months: forget the oldest
            del self.closed[next(iter(self.closed))]
        return out


def _rule(name, verdict, p, low, high, method) -> dict:
    return {
        "rule": name,
        "verdict": str(verdict),
        "probability": p,
        "low": low,
        "high": high,
        "method": method,
    }


def _plain(value):
    """Tuples as lists, for JSON."""
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


def _logsumexp(x: np.ndarray) -> float:
    top = x.max()
    return float(top + np.log(np.exp(x - top).sum()))
