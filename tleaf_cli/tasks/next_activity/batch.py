"""Cases padded into one batch of tensors for the next-activity model."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from tleaf_cli.data.event_logs import Case
from tleaf_cli.tasks.next_activity.encoding import TIME_FEATURES, Encoder

PAD = -100  # a padded step's activity and target (cross-entropy's ignore_index)


@dataclass
class CaseBatch:
    """B cases padded to the longest: activities, targets [B, T] (PAD past a length), times
    [B, T, F], lengths [B]."""

    cases: Sequence[Case]
    activities: torch.Tensor
    targets: torch.Tensor
    times: torch.Tensor
    lengths: torch.Tensor

    @classmethod
    def of(
        cls,
        cases: Sequence[Case],
        encoder: Encoder,
        device: torch.device,
        cache: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None,
    ) -> CaseBatch:
        """The cases as a batch; `cache` (case id -> activities, targets, times) keeps each
        case's arrays from one epoch to the next."""
        cache = {} if cache is None else cache
        for c in cases:
            if c.case_id not in cache:
                indices = encoder.indices(c)
                times = encoder.features(indices.tolist(), c.timestamps)
                cache[c.case_id] = indices, encoder.targets(c), times
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
    ) -> CaseBatch:
        """A batch of activity sequences whose times are the given timestamps (events past
        them placed by `Encoder.features`); targets PAD where not given."""
        parts = [
            (
                np.asarray(seq, dtype=np.int64),
                np.full(len(seq), PAD, dtype=np.int64) if targets is None else targets[i],
                encoder.features(list(seq), stamps),
            )
            for i, (seq, stamps) in enumerate(zip(activities, timestamps, strict=True))
        ]
        return cls.of_parts(parts, cases, device)

    @classmethod
    def of_parts(
        cls,
        parts: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
        cases: Sequence[Case],
        device: torch.device,
    ) -> CaseBatch:
        """Sequences given as (activities [n], targets [n], times [n, F]), padded into one
        batch."""
        lengths = [len(p[0]) for p in parts]
        b, t = len(parts), max(lengths)
        acts = np.full((b, t), PAD, dtype=np.int64)
        tgts = np.full((b, t), PAD, dtype=np.int64)
        times = np.zeros((b, t, TIME_FEATURES), dtype=np.float32)
        for i, (a, y, x) in enumerate(parts):
            acts[i, : len(a)], tgts[i, : len(a)], times[i, : len(a)] = a, y, x
        return cls(
            cases,
            torch.from_numpy(acts).to(device),
            torch.from_numpy(tgts).to(device),
            torch.from_numpy(times).to(device),
            torch.tensor(lengths, dtype=torch.long),
        )
