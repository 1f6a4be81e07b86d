"""Cases padded into one batch of tensors for the next-activity model."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from tleaf_cli.data.event_logs import Case
from tleaf_cli.tasks.next_activity.encoding import Encoder

PAD = -100  # a padded step's activity and target (cross-entropy's ignore_index)


Arrays = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""One sequence: activities [n], targets [n], event features [n, F] (time features and inputs:
`Encoder.features`), attribute values [n, K] and the next event's values [n, K] (K = 0 without
attributes: `Encoder.value_indices`)."""


@dataclass
class CaseBatch:
    """B cases padded to the longest: activities, targets [B, T] (PAD past a length), event
    features `times` [B, T, F] (time features, then any inputs), lengths [B], and each
    event's attribute values and the next event's, [B, T, K] (0 / PAD past a length)."""

    cases: Sequence[Case]
    activities: torch.Tensor
    targets: torch.Tensor
    times: torch.Tensor
    lengths: torch.Tensor
    attributes: torch.Tensor
    attribute_targets: torch.Tensor

    def logits(self, model) -> torch.Tensor:
        """The model's logits [B, T, V + 1] for this batch (its attributes read where it has
        any)."""
        return model(self.activities, self.times, self.lengths, self.attributes)

    @classmethod
    def of(
        cls,
        cases: Sequence[Case],
        encoder: Encoder,
        device: torch.device,
        cache: dict[str, Arrays] | None = None,
    ) -> CaseBatch:
        """The cases as a batch; `cache` (case id -> `Arrays`) keeps each case's arrays from
        one epoch to the next."""
        cache = {} if cache is None else cache
        for c in cases:
            if c.case_id not in cache:
                indices = encoder.indices(c)
                times = encoder.features(indices.tolist(), c.timestamps, encoder.input_columns(c))
                values = encoder.value_indices(c)
                targets = encoder.value_targets(values)
                cache[c.case_id] = indices, encoder.targets(c), times, values, targets
        return cls.of_parts([cache[c.case_id] for c in cases], cases, device)

    @classmethod
    def of_sequences(
        cls,
        activities: Sequence[Sequence[int]],
        timestamps: Sequence[Sequence],
        encoder: Encoder,
        device: torch.device,
        *,
        cases: Sequence[Case] = (),
        targets: Sequence[np.ndarray] | None = None,
        values: Sequence[np.ndarray] | None = None,
        inputs: Sequence[np.ndarray] | None = None,
    ) -> CaseBatch:
        """A batch of activity sequences whose times are the given timestamps and input
        columns `inputs` (`Encoder.input_columns` of a prefix each; events past them placed by
        `Encoder.features`), attribute values `values` ([n, K] each; none where not given);
        targets PAD where not given."""
        k = len(encoder.attributes)
        parts = [
            (
                np.asarray(seq, dtype=np.int64),
                np.full(len(seq), PAD, dtype=np.int64) if targets is None else targets[i],
                encoder.features(list(seq), stamps, None if inputs is None else inputs[i]),
                np.zeros((len(seq), k), dtype=np.int64) if values is None else values[i],
                np.full((len(seq), k), PAD, dtype=np.int64),
            )
            for i, (seq, stamps) in enumerate(zip(activities, timestamps, strict=True))
        ]
        return cls.of_parts(parts, cases, device)

    @classmethod
    def of_parts(
        cls,
        parts: Sequence[Arrays],
        cases: Sequence[Case],
        device: torch.device,
    ) -> CaseBatch:
        """Sequences given as `Arrays`, padded into one batch."""
        lengths = [len(p[0]) for p in parts]
        b, t, k, f = len(parts), max(lengths), parts[0][3].shape[1], parts[0][2].shape[1]
        acts = np.full((b, t), PAD, dtype=np.int64)
        tgts = np.full((b, t), PAD, dtype=np.int64)
        times = np.zeros((b, t, f), dtype=np.float32)
        values = np.zeros((b, t, k), dtype=np.int64)
        value_tgts = np.full((b, t, k), PAD, dtype=np.int64)
        for i, (a, y, x, v, w) in enumerate(parts):
            n = len(a)
            acts[i, :n], tgts[i, :n], times[i, :n], values[i, :n], value_tgts[i, :n] = a, y, x, v, w
        return cls(
            cases,
            torch.from_numpy(acts).to(device),
            torch.from_numpy(tgts).to(device),
            torch.from_numpy(times).to(device),
            torch.tensor(lengths, dtype=torch.long),
            torch.from_numpy(values).to(device),
            torch.from_numpy(value_tgts).to(device),
        )
