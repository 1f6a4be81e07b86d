"""The monitors' evidence as a block of q's vectors whose distance is a naive-Bayes score.

q_m's linear head reads the monitor shares (logic/monitors.py) as coordinates, so its vectors
are linear in them and a formula's distance to a trace is a quadratic in ψ(w) with weights
linear in the shares. What decides satisfaction from those shares is a product: read as
independent evidence (naive Bayes), monitor k accepting w says "satisfies" with log-odds
log(a_k / r_k) and rejecting it with log((1 − a_k) / (1 − r_k)), a_k and r_k the shares of the
formula's accepted and rejected words it accepts. The score

    s(φ, w) = Σ_k ψ_k(w) w_k(φ)  +  b_ρ(φ),
    w_k = log(a_k / r_k) − log((1 − a_k) / (1 − r_k)),
    b_ρ = Σ_{k in range ρ} log((1 − a_k) / (1 − r_k))

(ρ: the range of w's length; shares clipped to [ε, 1 − ε]) is a dot product u(φ) · v(w) with
u = [w ; b] and v = [ψ(w) ; onehot(ρ)]. On the unit sphere a dot product is a distance:

    ẑ_φ = [u ; 0 ; δ] / ‖[u ; δ]‖                 (a unit vector)
    ẑ_w = [v / M ; √(1 − ‖v‖² / M²) ; 0]           (unit, M² = F + 2 > ‖v‖²)
    ‖γ ẑ_φ − γ ẑ_w‖² = γ² (2 − 2 s(φ, w) / (‖[u ; δ]‖ M))

so the block's squared distance is below 2γ² exactly when the naive-Bayes score says
"satisfies", for every formula — the rule that, with no learning, decides 90 / 89 / 84 % of
Table I's test pairs (benchmarks/monitor_ceiling.py) where q's learned vectors keep 78 / 76 / 65
of it as a distance. The block is appended to q's learned vector (`--evidence`), so the
distance q's losses and the T-LEAF loss read is the learned part's plus this one, and the learned
part is trained on what the evidence gets wrong.

Only γ is learned. The cosine s / (‖[u ; δ]‖ M) is small (on Low, satisfying pairs 0.016 and
violating ones −0.013 on average), so γ² starts at `scale` (default 32: the block then parts the
two by about 2, the triplet margin's size; the Table I pipeline's 256 keeps the learned part's
distances from blurring the block's boundary on High); Adam moves log γ by about the learning
rate per step, so γ stays near its start, and from γ = 1 the block stayed too faint to matter
(measured: it shrank to γ² = 0.37, the distance rule 79.1 against the block's own 84.4).
Per-monitor weights learned beside it (c_k ψ_k w_k, starting at 1) made its own decisions
worse (84.4 against plain naive Bayes's 90.1 on Low's test pairs): the triplet loss does not ask
them to keep the boundary at s = 0. So the block is naive Bayes as it stands.
"""

from __future__ import annotations

import math

import torch
from torch import nn

from tleaf_cli.embed.graphs import EDGE
from tleaf_cli.errors import InputError
from tleaf_cli.logic.monitors import MonitorBank

EPS = 1e-3  # shares clipped to [EPS, 1 - EPS] (benchmarks/monitor_ceiling.py reads it too)
DELTA = 1e-3  # the formula side's own coordinate: keeps ẑ_φ a unit vector when u = 0


class MonitorEvidence(nn.Module):
    """The naive-Bayes block of q's vectors (see the module's docstring for the maths).

    Args:
        bank: the monitors q_m reads (`AutomatonEncoder.monitor_bank`): F monitors in R ranges.
        scale: γ² at the start (γ is learned).

    `formulas(monitor)` maps DFAs' monitor features [G, 2 R F] (accepted words' shares, then
    rejected words') to unit vectors [G, dim]; `traces(monitor, lengths)` maps words' features
    (ψ in their range's slots, as `meta_data.trace_monitor_features` lays them out; soft
    traces' expected ones too) and their lengths to unit vectors; both times γ.
    """

    def __init__(self, bank: MonitorBank, scale: float = 32.0) -> None:
        super().__init__()
        self.bank = bank
        self.features = bank.features  # R F
        self.log_scale = nn.Parameter(torch.tensor(0.5 * math.log(scale)))  # log γ
        self.trace_norm = float(bank.width + 2) ** 0.5  # M
        # the length range of a word of t letters, t = 0..max_length (longer: the last range),
        # read by index in `traces` instead of a Python call per trace of every batch
        ranges = [0] + [bank.range_of(t) for t in range(1, bank.max_length + 1)]
        self.register_buffer("range_of_length", torch.tensor(ranges), persistent=False)

    @property
    def dim(self) -> int:
        return self.features + self.bank.ranges + 2

    @property
    def boundary(self) -> float:
        """2γ²: the block's squared distance where the naive-Bayes score is 0."""
        return 2 * float(self.log_scale.detach().exp() ** 2)

    def formulas(self, monitor: torch.Tensor) -> torch.Tensor:
        return self.log_scale.exp() * self.formula_units(monitor)

    def traces(self, monitor: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        return self.log_scale.exp() * self.trace_units(monitor, lengths)

    def formula_units(self, monitor: torch.Tensor) -> torch.Tensor:
        """`formulas(monitor)` over γ: unit vectors that depend on the features alone (a
        trainer may compute them once per graph and scale them by γ in every batch)."""
        if monitor.shape[1] < 2 * self.features:
            raise InputError("the monitor evidence needs the rejected words' shares (runs readout)")
        a = monitor[:, : self.features].clamp(EPS, 1 - EPS)
        r = monitor[:, self.features : 2 * self.features].clamp(EPS, 1 - EPS)
        absent = torch.log((1 - a) / (1 - r))  # evidence of a monitor rejecting
        w = torch.log(a / r) - absent
        b = absent.reshape(len(a), self.bank.ranges, -1).sum(dim=2)
        pad = torch.zeros_like(b[:, :1])
        u = torch.cat([w, b, pad, torch.full_like(pad, DELTA)], dim=1)
        return nn.functional.normalize(u, dim=1)

    def trace_units(self, monitor: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        """`traces(monitor, lengths)` over γ (as `formula_units`)."""
        psi = monitor[:, : self.features]
        ranges = self.range_of_length[lengths.clamp(max=self.bank.max_length)]
        v = torch.cat([psi, nn.functional.one_hot(ranges, self.bank.ranges).to(psi)], dim=1)
        v = v / self.trace_norm
        pad = (1 - v.pow(2).sum(dim=1, keepdim=True)).clamp(min=1e-8).sqrt()
        return torch.cat([v, pad, torch.zeros_like(pad)], dim=1)


def chain_lengths(batch) -> torch.Tensor:
    """[graphs]: the letters of each trace chain in a batch (its edge nodes)."""
    on_edges = (batch.node_kind == EDGE).long()
    graphs = int(batch.ptr.numel() - 1)
    return torch.zeros(graphs, dtype=torch.long, device=on_edges.device).index_add_(
        0, batch.batch, on_edges
    )
