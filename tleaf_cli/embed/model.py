"""q's model: a formula encoder and a trace encoder into one space (`TripletEmbedder`), built from
its settings (`build_model`) the same way by the trainer (`train_meta`) and by the loader
(`load.load_embedder`).

`embedder="dfa"` (T-LEAF): formulas are expanded DFA graphs and traces chains, both through one
AutomatonEncoder (or, `encoder="authors"`, the authors' code's GCN, `paper_encoder.py`) whose edge
nodes carry the frozen q_e's vectors. `embedder="syntax"` (the
paper's baseline): formulas are parse trees through a SyntaxEncoder; traces as before.
"""

from __future__ import annotations

import torch
from torch import nn
from torch_geometric.data import Batch

from tleaf_cli.embed.automaton import AutomatonEncoder
from tleaf_cli.embed.batches import JointBatch, join
from tleaf_cli.embed.evidence import MonitorEvidence, chain_lengths
from tleaf_cli.embed.paper_encoder import AuthorsEncoder
from tleaf_cli.embed.radius import RadiusClassifier
from tleaf_cli.embed.syntax import SyntaxEncoder
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.meta import MetaSettings, widths_of


class TripletEmbedder(nn.Module):
    """A formula encoder and a trace encoder into one space (the same module for q_m).

    With `radius`, training also fits one radius for all formulas (`RadiusClassifier`).

    With `evidence` (a `MonitorEvidence`), each vector is followed by the monitors' naive-Bayes
    block, whose squared distance falls with the score (embed/evidence.py).

    With `sphere`, every vector is scaled to unit length, so squared distances lie in [0, 4].
    Without it the triplet loss on squared distances can be lowered by stretching the whole
    space; on the sphere the margin has a fixed meaning. With `evidence`, only the learned part
    is scaled: its squared distance (at most 4) then cannot blur the block's boundary.
    """

    def __init__(
        self,
        formula: nn.Module,
        trace: nn.Module,
        radius: RadiusClassifier | None = None,
        sphere: bool = False,
        evidence: MonitorEvidence | None = None,
    ):
        super().__init__()
        self.sphere = sphere
        self.evidence = evidence
        self.formula = formula
        self.trace = trace
        self.radius = radius

    def _out(self, z: torch.Tensor) -> torch.Tensor:
        """z, or with `sphere` z over its length (`_Unit`)."""
        return _Unit.apply(z) if self.sphere else z

    def embed_formulas(self, batch) -> torch.Tensor:
        return self._formula_vectors(self.formula(batch), batch)

    def embed_traces(self, batch) -> torch.Tensor:
        return self._trace_vectors(self.trace(batch), batch)

    def embed_both(self, formulas, traces) -> tuple[torch.Tensor, torch.Tensor]:
        """`embed_formulas(formulas)` and `embed_traces(traces)`; where one encoder reads both
        (q_m), in one pass over the two batches joined: the same vectors at half the layer
        calls."""
        if self.formula is not self.trace:
            return self.embed_formulas(formulas), self.embed_traces(traces)
        z = self.trace(join(formulas, traces))
        k = int(formulas.ptr.numel() - 1)
        return self._formula_vectors(z[:k], formulas), self._trace_vectors(z[k:], traces)

    def joint_vectors(self, batch: JointBatch, formulas: int) -> torch.Tensor:
        """[graphs, dim]: `embed_joined`'s vectors of a `JointStore` batch in one tensor, the
        formulas' rows, then the traces'."""
        if self.evidence is not None and batch.evidence is not None:
            # the block's unit vectors carried: scaled by γ, beside every graph's vector at once
            z = self._out(self.trace(batch))
            return torch.cat([z, self.evidence.log_scale.exp() * batch.evidence], dim=1)
        return torch.cat(self.embed_joined(batch, formulas))

    def embed_joined(self, batch, formulas: int) -> tuple[torch.Tensor, torch.Tensor]:
        """`embed_both` for one batch that holds the formulas' graphs, then the traces' chains
        (`formulas` graphs, then the rest; a `GraphStore`'s select of both, whose batches
        carry their matrices): the same vectors, with no batch joined. One encoder reads
        both (q_m)."""
        z = self._out(self.trace(batch))  # row by row: formulas and traces in one call
        z_formulas, z_traces = z[:formulas], z[formulas:]
        if self.evidence is None:
            return z_formulas, z_traces
        if isinstance(batch, JointBatch) and batch.evidence is not None:
            z = self.joint_vectors(batch, formulas)
            return z[:formulas], z[formulas:]
        monitor = self.trace.monitor_features(batch)
        if isinstance(batch, JointBatch):  # the traces' letters, carried
            lengths = batch.lengths
        else:
            lengths = chain_lengths(batch)[formulas:]
        return (
            torch.cat([z_formulas, self.evidence.formulas(monitor[:formulas])], dim=1),
            torch.cat([z_traces, self.evidence.traces(monitor[formulas:], lengths)], dim=1),
        )

    def _formula_vectors(self, z: torch.Tensor, batch) -> torch.Tensor:
        z = self._out(z)
        if self.evidence is None:
            return z
        return torch.cat([z, self.evidence.formulas(self.formula.monitor_features(batch))], dim=1)

    def _trace_vectors(self, z: torch.Tensor, batch) -> torch.Tensor:
        z = self._out(z)
        if self.evidence is None:
            return z
        evidence = self.evidence.traces(self.trace.monitor_features(batch), chain_lengths(batch))
        return torch.cat([z, evidence], dim=1)


def build_model(settings: MetaSettings, edge_dim: int, atom_table: torch.Tensor) -> TripletEmbedder:
    """q_m (or the syntax baseline) for resolved `settings` (`MetaSettings.resolved`)."""
    if settings.monitors is None or settings.evidence is None or settings.sphere is None:
        raise SettingError("monitors", "resolve the settings first (MetaSettings.resolved)")
    settings.check()
    if settings.encoder == "authors":  # the authors' code's GCN (embed/paper_encoder.py)
        encoder = AuthorsEncoder(
            edge_dim,
            widths=widths_of(settings.widths),
            directed=settings.directed,
            readout=settings.readout,
            paths=settings.paths,
            steps=settings.steps,
            walk_from=settings.walk_from,
            dead_state=settings.dead_state,
        )
        radius = RadiusClassifier(settings.margin) if settings.radius_weight > 0 else None
        return TripletEmbedder(encoder, encoder, radius, settings.sphere)
    trace = AutomatonEncoder(
        edge_dim,
        hidden=settings.hidden,
        layers=settings.layers,
        out_dim=settings.out_dim,
        steps=settings.steps,
        directed=settings.directed,
        readout=settings.readout,
        bins=settings.bins,
        max_length=settings.max_length,
        probes=settings.probes,
        monitors=settings.monitors,
        monitor_ranges=settings.monitor_ranges,
    )
    evidence = None
    radius_at = settings.margin
    if settings.evidence:
        evidence = MonitorEvidence(trace.monitor_bank, settings.evidence_scale)
        # the block's distances lie about 2γ² (its boundary), and Adam moves r slowly
        radius_at += evidence.boundary
    radius = RadiusClassifier(radius_at) if settings.radius_weight > 0 else None
    if settings.embedder == "dfa":
        return TripletEmbedder(trace, trace, radius, settings.sphere, evidence)
    formula = SyntaxEncoder(atom_table, settings.hidden, settings.layers, settings.out_dim)
    return TripletEmbedder(formula, trace, radius, settings.sphere)


def store_run_weights(encoder: AutomatonEncoder, graphs: list, batch: int = 512) -> None:
    """Give each graph its readout weights (`AutomatonEncoder.run_weights`), computed once in
    batches, so training does not recompute them for every batch that holds the graph."""
    for i in range(0, len(graphs), batch):
        part = graphs[i : i + batch]
        collated = Batch.from_data_list(part)
        weights = encoder.run_weights(collated).t()
        for k, g in enumerate(part):
            g.run_weights = weights[collated.ptr[k] : collated.ptr[k + 1]]


class _Unit(torch.autograd.Function):
    """z / max(‖z‖, 1e-12) row by row (`nn.functional.normalize(z, dim=-1)`'s values), its
    backward written out, (g − y (g · y)) / ‖z‖ for y = z / ‖z‖: five operators where
    autograd's backward of the norm and the division launches about fifteen. (For a row
    shorter than 1e-12, whose true gradient is g / 1e-12, this gives the sphere's tangent
    part only: q's vectors are never that short.)"""

    @staticmethod
    def forward(ctx, z: torch.Tensor) -> torch.Tensor:
        norm = z.norm(dim=-1, keepdim=True).clamp_min(1e-12)
        y = z / norm
        ctx.save_for_backward(y, norm)
        return y

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> torch.Tensor:
        y, norm = ctx.saved_tensors
        return (grad - y * (grad * y).sum(dim=-1, keepdim=True)) / norm
