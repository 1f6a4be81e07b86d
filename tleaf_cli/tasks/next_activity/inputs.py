"""Attributes a next-activity model reads but does not predict (`train-task next-activity
--inputs`): numbers and categories of the event or of the whole case, as extra event features.

The field's leaders read more than the activity and its time: the resource (Camargo et al.
2019), event attributes clustered (Hinkka et al. 2019), the case's own attributes (a loan's
amount, a patient's age). Each input named is one of

- an **event attribute** (`org:resource`, `CRP`): each event reads its own value;
- a **case attribute** (`case:AMOUNT_REQ`): every event of the case reads the case's value.

Each is read as one of two kinds, named by the user (numbers are often codes: a resource's
id): **numeric** (`--numeric-inputs`) — two columns, (x − mean) / sd of the training split's
values and a flag 1 where the event has no value (its first column then 0, the mean);
**categorical** (`--inputs`) — a one-hot over its `MAX_CATEGORIES` most frequent training values
and one column for any other value (unseen ones included), all zeros where there is none. These
columns go beside the time features (`encoding.Encoder.features`), so every model reads them
with only its input width changed. An event appended by the suffix search keeps its case's
case attributes and has no event attribute value. No torch here: arrays in, arrays out.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tleaf_cli.data.cases import Case, Cases
from tleaf_cli.errors import InputError

CASE_SCOPE = "case:"  # an input naming a case attribute: case:<attribute>
MAX_CATEGORIES = 32  # one-hot columns of a categorical input (its most frequent values)


@dataclass(frozen=True)
class AttributeInput:
    """One attribute read as input, with what its encoding measured on the training split."""

    name: str  # as named: an event attribute, or case:<attribute>
    kind: str  # numeric | categorical
    mean: float = 0.0  # numeric: the training values' mean and standard deviation
    scale: float = 1.0
    values: tuple[str, ...] = ()  # categorical: the values with a column of their own

    @property
    def of_case(self) -> bool:
        """Whether it is a case attribute (every event reads the case's value)."""
        return self.name.startswith(CASE_SCOPE)

    @property
    def attribute(self) -> str:
        """The attribute's name in the cases artifact (without `case:`)."""
        return self.name[len(CASE_SCOPE) :] if self.of_case else self.name

    @property
    def width(self) -> int:
        """Its columns: value and missing flag, or one per value and one for the rest."""
        return 2 if self.kind == "numeric" else len(self.values) + 1

    def raw(self, case: Case) -> Sequence[str | None]:
        """Its value at each event of the case (a case attribute's, repeated); InputError for
        a case that does not keep it (cases read without it)."""
        kept = case.case_attributes if self.of_case else case.attributes
        if self.attribute not in kept:
            raise InputError(
                f"case {case.case_id!r} keeps no {'case' if self.of_case else 'event'} attribute "
                f"{self.attribute!r}, which the model reads: read the log keeping it"
            )
        if self.of_case:
            return [kept[self.attribute]] * len(case)
        return kept[self.attribute]

    def encode(self, raw: Sequence[str | None], case: Case | None = None) -> np.ndarray:
        """float32 [n, width] of the values (None: none); InputError for a numeric input's
        value that is not a finite number (naming `case`)."""
        out = np.zeros((len(raw), self.width), dtype=np.float32)
        if self.kind == "numeric":
            for i, v in enumerate(raw):
                if v is None:
                    out[i, 1] = 1.0
                else:
                    out[i, 0] = (self.number(v, case, i) - self.mean) / self.scale
            return out
        column = {v: i for i, v in enumerate(self.values)}
        for i, v in enumerate(raw):
            if v is not None:
                out[i, column.get(v, len(self.values))] = 1.0
        return out

    def number(self, value: str, case: Case | None, event: int) -> float:
        """A numeric input's value as a finite number; InputError naming the case and event
        where it is not one."""
        try:
            x = float(value)
        except ValueError:
            x = math.nan
        if not math.isfinite(x):
            where = "" if case is None else f"case {case.case_id!r}, event {event + 1}: "
            raise InputError(
                f"{where}{self.name} is {value!r}, not a finite number (a numeric input); "
                "read it as a categorical one"
            )
        return x

    @classmethod
    def fit(cls, name: str, kind: str, train: Sequence[Case]) -> AttributeInput:
        """The input `name` of `kind` as the training cases `train` have it."""
        probe = cls(name, kind)
        if kind == "numeric":
            numbers = [
                probe.number(v, c, i)
                for c in train
                for i, v in enumerate(probe.raw(c))
                if v is not None
            ]
            if not numbers:
                return probe
            sd = float(np.std(numbers))
            return cls(name, kind, mean=float(np.mean(numbers)), scale=sd if sd > 0 else 1.0)
        counts = Counter(v for c in train for v in probe.raw(c) if v is not None)
        ranked = sorted(counts, key=lambda v: (-counts[v], v))[:MAX_CATEGORIES]
        return cls(name, kind, values=tuple(sorted(ranked)))


def fit_inputs(
    cases: Cases, categorical: Sequence[str], numeric: Sequence[str], train: Sequence[Case]
) -> tuple[AttributeInput, ...]:
    """The inputs of a cases artifact (the categorical, then the numeric ones), measured on
    `train`; InputError for an attribute the artifact does not keep, naming those it keeps of
    that scope first (case or event), then the others, as an input would name them."""
    event = list(cases.attribute_names)
    case = [CASE_SCOPE + n for n in cases.case_attribute_names]
    for name in [*categorical, *numeric]:
        probe = AttributeInput(name, "categorical")
        kept = cases.case_attribute_names if probe.of_case else cases.attribute_names
        if probe.attribute not in kept:
            scopes = {"case": case, "event": event}
            if not probe.of_case:
                scopes = {"event": event, "case": case}
            listed = "; ".join(
                f"{s} attributes: {', '.join(n) or 'none'}" for s, n in scopes.items()
            )
            raise InputError(
                f"{cases.path}: keeps no {next(iter(scopes))} attribute {probe.attribute!r} "
                f"({listed}); read the log keeping it"
            )
    kinds = [(n, "categorical") for n in categorical] + [(n, "numeric") for n in numeric]
    return tuple(AttributeInput.fit(n, kind, train) for n, kind in kinds)


def input_columns(inputs: Sequence[AttributeInput], case: Case) -> np.ndarray:
    """float32 [n, Σ width]: the case's events' input columns, in the inputs' order."""
    parts = [i.encode(i.raw(case), case) for i in inputs]
    return np.concatenate(parts, axis=1) if parts else np.zeros((len(case), 0), np.float32)


def extend_columns(inputs: Sequence[AttributeInput], known: np.ndarray, n: int) -> np.ndarray:
    """float32 [n, Σ width]: the `known` rows [k, Σ width] of a prefix, then n − k appended
    events': each keeps the case attributes' columns of the last known row and has no event
    attribute value."""
    k = len(known)
    if n <= k:
        return known[:n]
    out = np.zeros((n, known.shape[1]), dtype=np.float32)
    out[:k] = known
    start = 0
    for i in inputs:
        cols = slice(start, start + i.width)
        if i.of_case:
            out[k:, cols] = known[k - 1, cols] if k else 0.0
        elif i.kind == "numeric":
            out[k:, start + 1] = 1.0  # no value: the missing flag
        start += i.width
    return out
