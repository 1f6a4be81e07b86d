"""The LSTM as a suffix search's model, advancing each row by one event instead of rereading it.

A suffix search (suffix_search.py, suffix_sampling.py) calls its model once per step with every
open row, and each row is a row of the step before plus one token. Read from its first event, a
row costs the LSTM and the event features (datetimes, in Python) of every event it holds: O(L)
per row and step, O(L²) per suffix, and a sampled suffix of a long log (Sepsis: up to 185
events) is mostly that. The LSTM's state after a row is all it needs to read one event more, so
`LSTMCalls` keeps, from one call to the next, each row's state (h, c of every layer), its last
event's time and its length, and advances a row whose parent (the same row but its last token,
of the same prefix) the call before held by that one event: its features as `Encoder.features`
places an appended event (`Encoder.appended_events`, every row at once;
`Encoder.appended_inputs`). A row it does not hold (the first call, a prefix given whole) is
read whole. Only the last call's rows are held: memory is that call's rows × layers × 2 × hidden
floats.

The answer is the whole reading's (`joint_log_probs` without the cache), to float precision:
tests/test_lstm_calls.py compares the two on random rows, with attributes and inputs.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime

import numpy as np
import torch

from tleaf_cli.tasks.next_activity.batch import CaseBatch
from tleaf_cli.tasks.next_activity.encoding import Encoder, clock
from tleaf_cli.tasks.next_activity.model import NextActivityLSTM
from tleaf_cli.tasks.next_activity.suffix_search import Rows

WHOLE_CHUNK = 1024  # rows read whole per LSTM call
STEP_CHUNK = 16_384  # rows advanced by one event per LSTM call


class LSTMCalls:
    """`NextLogProbs` of an LSTM run over `tokens` (joint_tokens.JointTokens: activities, or
    events with attribute values), the rows' times and input columns those of their prefixes
    (`stamps[owner]`, `inputs[owner]`), as `joint_tokens.joint_log_probs`; `scores(last, n)`
    turns the LSTM's state after each row into the row's log-probabilities [n, tokens + 1]."""

    def __init__(
        self,
        model: NextActivityLSTM,
        encoder: Encoder,
        tokens,
        stamps: Sequence[Sequence[datetime]],
        inputs: Sequence[np.ndarray] | None,
        scores,
    ) -> None:
        self.model = model
        self.encoder = encoder
        self.tokens = tokens
        self.stamps = stamps
        self.inputs = inputs
        self.scores = scores
        self._held: dict[tuple[int, tuple[int, ...]], int] = {}  # (owner, row) -> slot
        self._h = self._c = None  # [layers, held rows, hidden]
        self._clocks = np.zeros(0)  # per slot: the row's last event's time (`clock`)
        self._first = np.array([clock(s[0]) for s in stamps])  # per owner: its first event's
        self._gaps = np.asarray(encoder.activity_gap, dtype=np.float64)
        self._appended: dict[int, np.ndarray] = {}  # owner -> an appended event's inputs

    def __call__(self, rows: Rows) -> np.ndarray:
        n = len(rows)
        parents = [
            self._held.get((o, row[:-1])) if len(row) > len(self.stamps[o]) else None
            for row, o in zip(rows, rows.owners, strict=True)
        ]
        stepped = [i for i, p in enumerate(parents) if p is not None]
        whole = [i for i, p in enumerate(parents) if p is None]
        layers, hidden = self.model.lstm.num_layers, self.model.lstm.hidden_size
        h = torch.zeros(layers, n, hidden)
        c = torch.zeros(layers, n, hidden)
        last = torch.zeros(n, hidden)
        times = np.zeros(n)
        with torch.no_grad():
            for start in range(0, len(whole), WHOLE_CHUNK):
                part = whole[start : start + WHOLE_CHUNK]
                self._read_whole(rows, part, h, c, last, times)
            for start in range(0, len(stepped), STEP_CHUNK):
                part = stepped[start : start + STEP_CHUNK]
                self._advance(rows, part, [parents[i] for i in part], h, c, last, times)
            out = self.scores(last, n)
        self._held = {(o, row): i for i, (row, o) in enumerate(zip(rows, rows.owners, strict=True))}
        self._h, self._c, self._clocks = h, c, times
        return out

    def _read_whole(self, rows: Rows, part, h, c, last, times) -> None:
        """Rows read from their first event (joint_log_probs' way), their states kept."""
        owners = [rows.owners[i] for i in part]
        decoded = [self.tokens.decode(rows[i]) for i in part]
        batch = CaseBatch.of_sequences(
            [a for a, _ in decoded],
            [self.stamps[o] for o in owners],
            self.encoder,
            torch.device("cpu"),
            values=[vs for _, vs in decoded],
            inputs=None if self.inputs is None else [self.inputs[o] for o in owners],
        )
        x = self.model.inputs(batch.activities, batch.times, batch.attributes)
        states, (h_n, c_n) = self.model.run(x, batch.lengths)
        index = torch.tensor(part)
        last[index] = states[torch.arange(len(part)), batch.lengths - 1]
        h[:, index], c[:, index] = h_n, c_n
        for i, (activities, _), o in zip(part, decoded, owners, strict=True):
            times[i] = self._last_time(activities.tolist(), o)

    def _last_time(self, activities: list[int], owner: int) -> float:
        """The `clock` of the time `Encoder.features` gives a row's last event."""
        stamps = self.stamps[owner]
        t = clock(stamps[min(len(activities), len(stamps)) - 1])
        return t + float(self._gaps[activities[len(stamps) :]].sum())

    def _advance(self, rows: Rows, part, parents, h, c, last, times) -> None:
        """Rows one event past a row of the last call: that row's state, one LSTM step."""
        activities, values = self.tokens.decode([rows[i][-1] for i in part])
        owners = [rows.owners[i] for i in part]
        features, now = self.encoder.appended_events(
            activities,
            np.array([len(rows[i]) for i in part]),
            self._clocks[parents],
            self._first[owners],
        )
        times[part] = now
        if self.encoder.inputs:
            for o in set(owners) - set(self._appended):
                known = None if self.inputs is None else self.inputs[o]
                self._appended[o] = self.encoder.appended_inputs(known)
            columns = np.stack([self._appended[o] for o in owners])
            features = np.concatenate([features, columns], axis=1)
        x = self.model.inputs(
            torch.from_numpy(activities)[:, None],
            torch.from_numpy(features)[:, None],
            torch.from_numpy(values)[:, None] if self.encoder.attributes else None,
        )
        held = torch.tensor(parents)
        index = torch.tensor(part)
        state = (self._h[:, held].contiguous(), self._c[:, held].contiguous())
        out, (h_n, c_n) = self.model.lstm(x, state)
        last[index] = out[:, 0]
        h[:, index], c[:, index] = h_n, c_n
