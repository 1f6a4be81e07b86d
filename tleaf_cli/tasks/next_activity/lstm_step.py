"""One step of a trained `NextActivityLSTM` in numpy, from its cached hidden and cell state:
what lets the live stream (stream.py) answer an event with one LSTM step, without torch's
per-call cost (most of an event's time) and without re-reading the case."""

from __future__ import annotations

import numpy as np

from tleaf_cli.tasks.next_activity.model import NextActivityLSTM


class LSTMStep:
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
