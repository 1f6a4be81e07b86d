"""Cases as a next-activity model's inputs and targets, in the shape of Tax et al. (CAiSE 2017).

Vocabulary: the log's activities as atoms, index i = `atoms[i]` (sorted, so a run and its
evaluation agree), and index V = **end of case**. A case a_1..a_n gives n steps; step t reads
event t — activity a_t one-hot and five time features — and its target is a_{t+1}, or the end
for t = n. A causal LSTM over the whole case thus learns every prefix's next activity at once
(the same terms as Tax et al.'s training on each prefix apart), and accuracy over a case's
steps is accuracy pooled over its prefixes of length 1..n with the end as a target.

Time features of event t (divisors are means over the training split, so they are ~1):
position t / mean case length; seconds since event t−1 / mean gap; seconds since the case's
first event / mean elapsed time; seconds since midnight / 86400; weekday / 7 (all UTC).

With `attributes` (event attributes the cases artifact keeps, `read-log --attributes
org:resource`), each event also reads its value of each, an index into the values the training
split has (`values[k]`; index 0: none, or a value training never saw), and each step's targets
add the next event's values (`attribute_targets`; PAD where the next event has none or an
unseen one, and at the last step).

With `inputs` (inputs.py: attributes read but not predicted, categorical or numeric, of the
event or of the case), each event's features add their columns after the time features
(`feature_count` in all).

Suffix prediction appends activities whose times are not known: an appended event is placed
its activity's mean gap (training split) after the event before it (`Encoder.features` with
fewer timestamps than activities). No torch here: arrays in, arrays out.
"""

from __future__ import annotations

import calendar
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from datetime import datetime, timedelta

import numpy as np

from tleaf_cli.data.event_logs import Case, Cases
from tleaf_cli.errors import InputError
from tleaf_cli.tasks.next_activity.inputs import (
    AttributeInput,
    extend_columns,
    fit_inputs,
    input_columns,
)

TIME_FEATURES = 5
_DAY = 86400.0
_THURSDAY = 3  # 1970-01-01's weekday (Monday 0)


@dataclass(frozen=True)
class Encoder:
    """What turns cases into arrays: the vocabulary and the training split's time scales."""

    atoms: tuple[str, ...]  # index i: activity atom i; index len(atoms): end of case
    activities: tuple[str, ...]  # the activities' own names, in the atoms' order
    mean_length: float
    mean_gap: float  # seconds between consecutive events
    mean_elapsed: float  # seconds since the case's first event
    activity_gap: tuple[float, ...]  # per activity: mean seconds since the event before it
    attributes: tuple[str, ...] = ()  # event attributes read and predicted, in order
    values: tuple[tuple[str, ...], ...] = ()  # per attribute: its training values (index i + 1)
    inputs: tuple[AttributeInput, ...] = ()  # attributes read only, their columns in order

    @property
    def end(self) -> int:
        """The end-of-case token's index (= the number of activities)."""
        return len(self.atoms)

    def names(self) -> dict[str, str]:
        """Activity name -> atom, as the log's cases artifact mapped them: how a rule file that
        names activities (a `.decl`) finds the run's atoms."""
        return dict(zip(self.activities, self.atoms, strict=True))

    @property
    def value_counts(self) -> tuple[int, ...]:
        """Per attribute, the indices its values take: its training values and 0 (none)."""
        return tuple(len(v) + 1 for v in self.values)

    @property
    def feature_count(self) -> int:
        """F, the features of each event: the time features, then the inputs' columns."""
        return TIME_FEATURES + sum(i.width for i in self.inputs)

    @classmethod
    def fit(
        cls,
        cases: Cases,
        split: str = "train",
        attributes: Sequence[str] = (),
        inputs: Sequence[str] = (),
        numeric_inputs: Sequence[str] = (),
    ) -> Encoder:
        """The encoder of a cases artifact, its time scales, attribute values and inputs
        measured on `split`; InputError for an attribute the artifact does not keep."""
        missing = [a for a in attributes if a not in cases.attribute_names]
        if missing:
            kept = ", ".join(cases.attribute_names) or "none"
            raise InputError(
                f"{cases.path}: keeps no event attribute {missing[0]!r} (it keeps: {kept}); "
                "read the log keeping it"
            )
        atom_of = cases.activity_atoms
        pairs = sorted((atom, name) for name, atom in atom_of.items())
        atoms = tuple(a for a, _ in pairs)
        index = {a: i for i, a in enumerate(atoms)}
        train = [c for c in cases.cases if c.split == split]
        if not train:
            raise InputError(f"{cases.path}: no cases in the {split} split")
        gaps, elapsed, per_activity = [], [], [[] for _ in atoms]
        for case in train:
            seconds = _seconds(case.timestamps)
            for t in range(1, len(case)):
                gap = seconds[t] - seconds[t - 1]
                gaps.append(gap)
                per_activity[index[case.atoms[t]]].append(gap)
            elapsed.extend(seconds - seconds[0])
        mean_gap = float(np.mean(gaps)) if gaps else 0.0
        return cls(
            atoms=atoms,
            activities=tuple(n for _, n in pairs),
            mean_length=float(np.mean([len(c) for c in train])),
            mean_gap=mean_gap,
            mean_elapsed=float(np.mean(elapsed)),
            activity_gap=tuple(float(np.mean(g)) if g else mean_gap for g in per_activity),
            attributes=tuple(attributes),
            values=tuple(
                tuple(sorted({v for c in train for v in c.attributes[a] if v is not None}))
                for a in attributes
            ),
            inputs=fit_inputs(cases, inputs, numeric_inputs, train),
        )

    def as_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> Encoder:
        out = {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}
        out["values"] = tuple(tuple(v) for v in d.get("values", ()))
        out["inputs"] = tuple(
            AttributeInput(**{**i, "values": tuple(i.get("values", ()))})
            for i in d.get("inputs", ())
        )
        return cls(**out)

    def input_columns(self, case: Case) -> np.ndarray:
        """float32 [n, feature_count − TIME_FEATURES]: the case's events' input columns."""
        return input_columns(self.inputs, case)

    def value_indices(self, case: Case) -> np.ndarray:
        """int64 [n, K]: each event's index of each attribute's value (0: none or unseen)."""
        out = np.zeros((len(case), len(self.attributes)), dtype=np.int64)
        for k, (name, values) in enumerate(zip(self.attributes, self.values, strict=True)):
            index = {v: i + 1 for i, v in enumerate(values)}
            out[:, k] = [index.get(v, 0) for v in case.attributes[name]]
        return out

    def value_targets(self, values: np.ndarray) -> np.ndarray:
        """int64 [n, K]: step t's next event's value indices, from `value_indices` [n, K]; the
        loss ignores (PAD = -100) none, unseen and the last step (no next event)."""
        out = np.full_like(values, -100)
        out[:-1] = np.where(values[1:] > 0, values[1:], -100)
        return out

    def knows(self, case: Case) -> bool:
        """Whether every activity of the case is in the vocabulary."""
        return set(case.atoms) <= set(self.atoms)

    def indices(self, case: Case, unknown: int | None = None) -> np.ndarray:
        """int64 [n]: the case's activity indices; an activity the encoder has not seen is
        `unknown` where given (an index no prediction has: a test case's activity training
        never saw), else an InputError (a cases artifact other than the run's)."""
        index = {a: i for i, a in enumerate(self.atoms)}
        try:
            if unknown is not None:
                return np.array([index.get(a, unknown) for a in case.atoms], dtype=np.int64)
            return np.array([index[a] for a in case.atoms], dtype=np.int64)
        except KeyError as missing:
            raise InputError(
                f"case {case.case_id!r}: activity atom {missing.args[0]} is not in the model's "
                f"vocabulary ({len(self.atoms)} activities): the run was trained on another log"
            ) from None

    def targets(self, case: Case) -> np.ndarray:
        """int64 [n]: step t's next activity, the end token at the last step."""
        return np.append(self.indices(case)[1:], self.end)

    def features(
        self,
        activities: Sequence[int],
        timestamps: Sequence[datetime],
        inputs: np.ndarray | None = None,
    ) -> np.ndarray:
        """float32 [n, feature_count] for `activities`; events past the given `timestamps`
        are placed their activity's mean gap after the event before them, and past the given
        input columns `inputs` ([k, ...], `input_columns` of the case or of its prefix; none:
        no event has a value) keep the case attributes and have no event attribute value."""
        if not timestamps:
            raise InputError("a case's features need at least its first event's time")
        times = list(timestamps[: len(activities)])
        for a in activities[len(times) :]:
            times.append(times[-1] + timedelta(seconds=self.activity_gap[a]))
        seconds = _seconds(times)
        gap = np.diff(seconds, prepend=seconds[0])
        clocks = np.array([clock(t) for t in times])
        time = self._time_rows(np.arange(1, len(times) + 1), gap, seconds, clocks)
        if not self.inputs:
            return time
        if inputs is None:
            inputs = np.zeros((0, self.feature_count - TIME_FEATURES), dtype=np.float32)
        return np.concatenate([time, extend_columns(self.inputs, inputs, len(times))], axis=1)

    def appended_events(
        self,
        activities: np.ndarray,
        positions: np.ndarray,
        previous: np.ndarray,
        first: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Events of `activities` [n] appended at `positions` (1-based) after events at the
        clocks `previous` [n] (`clock`), in cases that began at `first` [n]: their time
        features float32 [n, TIME_FEATURES] and their clocks; `features`' for events past the
        given timestamps, many rows at a time (a suffix search advancing its rows by one
        event)."""
        gaps = np.asarray(self.activity_gap, dtype=np.float64)[activities]
        now = previous + gaps
        return self._time_rows(positions, gaps, now - first, now), now

    def appended_inputs(self, inputs: np.ndarray | None) -> np.ndarray:
        """float32 [feature_count − TIME_FEATURES]: the input columns of an event appended
        after the given ones `inputs` (as `features` places them: the case attributes kept, no
        event attribute value)."""
        width = self.feature_count - TIME_FEATURES
        known = np.zeros((0, width), dtype=np.float32) if inputs is None else inputs
        return extend_columns(self.inputs, known, len(known) + 1)[-1]

    def _time_rows(
        self,
        positions: np.ndarray,
        gaps: np.ndarray,
        elapsed: np.ndarray,
        clocks: np.ndarray,
    ) -> np.ndarray:
        """float32 [n, TIME_FEATURES] of events at `positions` (1-based), `gaps` seconds after
        the event before them, `elapsed` seconds after the case's first, at `clocks`."""
        days, midnight = np.divmod(clocks, _DAY)
        return np.stack(
            [
                positions / max(self.mean_length, 1e-9),
                gaps / max(self.mean_gap, 1e-9),
                elapsed / max(self.mean_elapsed, 1e-9),
                midnight / _DAY,
                (days + _THURSDAY) % 7 / 7.0,
            ],
            axis=1,
        ).astype(np.float32)


def clock(t: datetime) -> float:
    """Seconds from 1970-01-01 00:00 to `t` read by its own fields (its date and time of day,
    whatever its time zone): what the time of day and the weekday are read from."""
    return calendar.timegm(t.timetuple()) + t.microsecond / 1e6


def _seconds(times: Sequence[datetime]) -> np.ndarray:
    """float64 [n]: seconds since the first of `times`."""
    first = times[0]
    return np.array([(t - first).total_seconds() for t in times], dtype=np.float64)
