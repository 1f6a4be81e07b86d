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
  event costs one LSTM step (`_Cell`: the model's weights stepped in numpy; the new event's
  features read off it, the one before it and the case's first); any other model (the
  transformer, the prefix table) re-reads the whole prefix at each event, as the batch
  predictor does. The rule probabilities
  (`samples` > 0) and the suffix and recommendation (`suffix=True`) re-read the prefix too:
  they are `Predictor`'s, on the case as it stands.

An event whose activity the run never saw is not skipped: the case goes on, its verdicts
updated (the event's letter is its own atom: a rule naming that activity reads it, the others
read another activity), but the model cannot read the prefix any more, so from that event on the
case's prediction is null with its `reason` — as a batch row of such a prefix. An end mark
(`"end": true`, with an event or alone) closes the case: the line gives its final verdicts (the
case ended, so a temporarily satisfied rule is permanently satisfied, a temporarily violated
one permanently violated), the case is dropped, and a later event for it is refused.

A bad event raises a `BadEvent` whose `reason` is one of `REASONS`, and changes nothing:
`run_stream` reports it, counts it and goes on. `read_lines` reads stdin or follows a growing
file (like `tail -f`).
"""

from __future__ import annotations

import functools
import json
import os
import queue
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import torch

from tleaf_cli.data.activity_names import attribute_atom, bind_atoms
from tleaf_cli.data.cases import Case
from tleaf_cli.errors import InputError
from tleaf_cli.logic.verdicts import Verdict
from tleaf_cli.tasks.next_activity.joint_tokens import joint_log_probs
from tleaf_cli.tasks.next_activity.model import NextActivityLSTM
from tleaf_cli.tasks.next_activity.monitoring import MonitoredRules, sample_holds, wilson
from tleaf_cli.tasks.next_activity.predict import Predictor
from tleaf_cli.tasks.next_activity.suffix_search import Rows

MALFORMED = "malformed JSON"
MISSING = "missing field"
BAD_FIELD = "bad field"
OUT_OF_ORDER = "timestamp before the case's previous event"
CLOSED = "case already ended"
NOT_OPEN = "end mark for a case not open"
REASONS = (MALFORMED, MISSING, BAD_FIELD, OUT_OF_ORDER, CLOSED, NOT_OPEN)
UNKNOWN_ACTIVITY = "unknown activity"  # not skipped: the case goes on without a prediction
ENDED = "the case ended"  # the reason of an end mark's line: no next event to predict
CASE_SCOPE = "case:"  # an attribute named case:<name> is a case attribute
_LETTER_CACHE = 1 << 16  # distinct event letters whose columns are kept
_attribute_atom = functools.lru_cache(maxsize=1 << 16)(attribute_atom)  # values repeat


class BadEvent(InputError):
    """An input line that is not a usable event (`reason`: one of `REASONS`); nothing changed."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


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


class _Cell:
    """A `NextActivityLSTM`'s layers as numpy arrays, one step of one case at a time: what
    torch's LSTM computes (gates i, f, g, o), without its per-call cost (a tenth of a
    millisecond against a few microseconds for a 100-unit cell)."""

    def __init__(self, model: NextActivityLSTM) -> None:
        lstm = model.lstm
        self.layers = lstm.num_layers
        self.inputs = lstm.input_size

        def array(name: str) -> np.ndarray:
            return getattr(lstm, name).detach().cpu().numpy().astype(np.float32)

        self.w_ih = [array(f"weight_ih_l{k}") for k in range(self.layers)]
        self.w_hh = [array(f"weight_hh_l{k}") for k in range(self.layers)]
        self.b_ih = [array(f"bias_ih_l{k}") for k in range(self.layers)]
        self.b_hh = [array(f"bias_hh_l{k}") for k in range(self.layers)]
        self.hidden = lstm.hidden_size
        self.out_weight = model.out.weight.detach().cpu().numpy().astype(np.float32)
        self.out_bias = model.out.bias.detach().cpu().numpy().astype(np.float32)
        self.embeddings = [
            e.weight.detach().cpu().numpy().astype(np.float32) for e in model.values.embeddings
        ]

    def step(
        self, x: np.ndarray, memory: tuple[np.ndarray, np.ndarray] | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(h, c), each float32 [layers, hidden], after input x [inputs] from `memory`."""
        h0, c0 = memory if memory is not None else (None, None)
        hs, cs = [], []
        for k in range(self.layers):
            gates = self.w_ih[k] @ x + self.b_ih[k] + self.b_hh[k]
            c_before = np.zeros(self.hidden, dtype=np.float32) if c0 is None else c0[k]
            if h0 is not None:
                gates += self.w_hh[k] @ h0[k]
            i, f, g, o = np.split(gates, 4)
            c = _sigmoid(f) * c_before + _sigmoid(i) * np.tanh(g)
            h = _sigmoid(o) * np.tanh(c)
            hs.append(h)
            cs.append(c)
            x = h
        return np.stack(hs), np.stack(cs)


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-x))


def _logsumexp(x: np.ndarray) -> float:
    top = x.max()
    return float(top + np.log(np.exp(x - top).sum()))


class StreamMonitor:
    """The open cases of a stream and what a run says about each after every event (module
    docstring). `predictor.settings` give top-k, samples, max-suffix, seed and the suffix's
    way; `suffix`: also the predicted rest of the case and the recommendation (they cost a
    search per event)."""

    def __init__(self, predictor: Predictor, suffix: bool = False) -> None:
        self.predictor = predictor
        self.settings = predictor.settings
        self.suffix = suffix
        self.encoder = predictor.encoder
        self.tokens = predictor.tokens
        self.rules = predictor.rules
        self.model = predictor.model
        self.lstm = isinstance(self.model, NextActivityLSTM)
        self.cell = _Cell(self.model) if self.lstm else None
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
        self.closed: set[str] = set()

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
            raise BadEvent(MALFORMED, f"not a JSON line ({_first_line(e)})") from None
        if not isinstance(event, dict):
            raise BadEvent(MALFORMED, f"a JSON {type(event).__name__}, not an object")
        return self.feed(event, line)

    def feed(self, event: Mapping, line: int | None = None) -> dict:
        """The output line's content after `event` (module docstring; `line`: the input line's
        number, echoed); BadEvent, nothing changed, for an event that cannot be taken."""
        case_id, activity, stamp, attributes, end = _fields(event)
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
        self.closed.add(case.case_id)
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


def _first_line(e: Exception) -> str:
    return str(e).splitlines()[0] if str(e) else type(e).__name__


def _fields(event: Mapping) -> tuple[str, str | None, datetime | None, dict, bool]:
    """(case id, activity or None for an end mark alone, UTC time, attributes, end) of an
    event; BadEvent for a field missing or of the wrong kind."""
    if "case" not in event:
        raise BadEvent(MISSING, "no 'case'")
    case_id = event["case"]
    if isinstance(case_id, bool) or not isinstance(case_id, str | int) or case_id == "":
        raise BadEvent(BAD_FIELD, f"'case' must be a non-empty string, not {case_id!r}")
    case_id = str(case_id)
    end = event.get("end", False)
    if end is None:
        end = False
    if not isinstance(end, bool):
        raise BadEvent(BAD_FIELD, f"'end' must be true or false, not {end!r}")
    activity = event.get("activity")
    if activity is None:
        if end:  # the mark alone: its other fields are not read
            return case_id, None, None, {}, True
        raise BadEvent(MISSING, f"case {case_id!r}: no 'activity'")
    if not isinstance(activity, str) or not activity:
        raise BadEvent(BAD_FIELD, f"'activity' must be a non-empty string, not {activity!r}")
    if "timestamp" not in event or event["timestamp"] is None:
        raise BadEvent(MISSING, f"case {case_id!r}: no 'timestamp'")
    text = event["timestamp"]
    try:
        if not isinstance(text, str):
            raise ValueError
        stamp = datetime.fromisoformat(text.strip())
    except ValueError:
        raise BadEvent(BAD_FIELD, f"'timestamp' is no ISO 8601 time: {text!r}") from None
    stamp = stamp.replace(tzinfo=UTC) if stamp.tzinfo is None else stamp.astimezone(UTC)
    raw = event.get("attributes") or {}
    if not isinstance(raw, dict):
        raise BadEvent(BAD_FIELD, f"'attributes' must be an object, not {raw!r}")
    attributes: dict[str, str | None] = {}
    for name, value in raw.items():
        if value is None or isinstance(value, str):
            attributes[name] = value
        elif isinstance(value, bool):
            attributes[name] = "true" if value else "false"
        elif isinstance(value, int | float):
            attributes[name] = str(value)
        else:
            raise BadEvent(BAD_FIELD, f"attribute {name!r}: a value, not {value!r}")
    return case_id, activity, stamp, attributes, end


# -------------------------------------------------------------------- the loop
@dataclass
class StreamSummary:
    """What a stream did: lines read (blank ones not counted), output lines, the lines skipped
    by reason, events with an activity the run never saw (not skipped), cases ended, cases
    still open, whether it was interrupted, seconds."""

    lines: int = 0
    written: int = 0
    skipped: Counter = field(default_factory=Counter)
    unknown_activity: int = 0
    ended: int = 0
    open: int = 0
    interrupted: bool = False
    seconds: float = 0.0

    def as_dict(self) -> dict:
        return {
            "lines": self.lines,
            "written": self.written,
            "skipped": sum(self.skipped.values()),
            "skipped_by_reason": dict(sorted(self.skipped.items())),
            "unknown_activity": self.unknown_activity,
            "ended": self.ended,
            "open": self.open,
            "interrupted": self.interrupted,
            "seconds": round(self.seconds, 3),
        }

    def line(self) -> str:
        """The one-line account at the end of a stream."""
        skipped = sum(self.skipped.values())
        reasons = ", ".join(f"{n} {r}" for r, n in sorted(self.skipped.items()))
        return (
            f"{self.lines} lines read, {self.written} predictions written"
            + (f", {skipped} skipped ({reasons})" if skipped else ", none skipped")
            + (
                f", {self.unknown_activity} events with an activity the run never saw "
                "(verdicts only)"
                if self.unknown_activity
                else ""
            )
            + f"; {self.ended} cases ended, {self.open} still open"
            + (" (interrupted)" if self.interrupted else "")
        )


def run_stream(
    monitor: StreamMonitor,
    lines: Iterable[str | bytes],
    write: Callable[[str], None],
    report: Callable[[str], None],
) -> StreamSummary:
    """Feed every line to `monitor`, `write` each output line (JSON, no newline), `report` each
    skipped line and each event of an activity the run never saw (one line naming the input
    line's number and why); stops at the end of `lines` or at an interrupt (Ctrl-C)."""
    summary = StreamSummary()
    start = time.perf_counter()
    try:
        for number, text in enumerate(lines, 1):
            if not text.strip():
                continue
            summary.lines += 1
            try:
                out = monitor.feed_line(text, number)
            except BadEvent as e:
                summary.skipped[e.reason] += 1
                report(f"line {number}: skipped, {e.reason}: {e}")
                continue
            write(json.dumps(out, ensure_ascii=False))
            summary.written += 1
            summary.ended += bool(out["ended"])
            if not monitor.knows(out["activity"]):
                summary.unknown_activity += 1
                report(
                    f"line {number}: {UNKNOWN_ACTIVITY} {out['activity']!r}: the run never saw "
                    f"it; case {out['case_id']!r} goes on with verdicts only, no prediction"
                )
    except KeyboardInterrupt:
        summary.interrupted = True
    summary.open = len(monitor.open)
    summary.seconds = time.perf_counter() - start
    return summary


def read_lines(
    source: str | os.PathLike,
    follow: bool = True,
    until_idle: float | None = None,
    poll: float = 0.05,
) -> Iterator[bytes]:
    """The lines of `source`: `-` is stdin, read to its end (or until no line came for
    `until_idle` seconds); a file is read to its end and, with `follow`, kept being read as it
    grows (a line counted once its newline is written) until `until_idle` seconds pass with
    nothing new (None: until interrupted). A file that shrinks is read again from its start."""
    if os.fspath(source) == "-":
        yield from _stdin_lines(until_idle)
        return
    with open(source, "rb") as f:
        pending = b""
        idle_since = time.monotonic()
        while True:
            chunk = f.readline()
            if chunk:
                pending += chunk
                if pending.endswith(b"\n"):
                    yield pending
                    pending = b""
                idle_since = time.monotonic()
                continue
            if not follow or (
                until_idle is not None and time.monotonic() - idle_since >= until_idle
            ):
                break
            if os.fstat(f.fileno()).st_size < f.tell():  # truncated: start again
                f.seek(0)
                pending = b""
            time.sleep(poll)
        if pending:
            yield pending


def _stdin_lines(until_idle: float | None) -> Iterator[bytes]:
    stream = getattr(sys.stdin, "buffer", sys.stdin)
    done = "" if stream is sys.stdin else b""  # readline's answer at the end
    if until_idle is None:
        yield from iter(stream.readline, done)
        return
    lines: queue.Queue = queue.Queue()

    def pump() -> None:
        for line in iter(stream.readline, done):
            lines.put(line)
        lines.put(None)

    threading.Thread(target=pump, daemon=True).start()
    while True:
        try:
            line = lines.get(timeout=until_idle)
        except queue.Empty:
            return
        if line is None:
            return
        yield line


def summary_path(out: str | os.PathLike) -> Path:
    """The summary JSON written beside a stream's output file: predictions.jsonl ->
    predictions.summary.json."""
    out = Path(out)
    return out.with_name(f"{out.stem}.summary.json")
