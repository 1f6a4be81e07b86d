"""A trained q (frozen q_e + q_m) at work: formulas, DFAs, discrete and soft traces to vectors.

`load.load_embedder` reads a model folder into an `Embedder`; the logic loss (losses/tleaf.py),
`tleaf embed` and the evaluations use it. Nothing here trains.

Soft traces (a model's per-step probabilities) are read as in `soft_traces.py`.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

import numpy as np
import torch
from torch_geometric.data import Batch

from tleaf_cli import arguments
from tleaf_cli.data.dfa_table import dfa_from_row
from tleaf_cli.data.monitor_cache import monitor_shares
from tleaf_cli.embed.graphs import syntax_graph
from tleaf_cli.embed.meta_data import (
    GuardVectors,
    chain_batch,
    dfa_batch,
    guard_keys,
    trace_inputs,
)
from tleaf_cli.embed.model import TripletEmbedder
from tleaf_cli.embed.soft_monitors import (
    AlphabetWalk,
    monitor_classes,
    soft_monitor_features,
)
from tleaf_cli.embed.soft_traces import (
    letter_keys,
    letter_probabilities,
    one_hot_truth,
    soft_trace_vectors,
)
from tleaf_cli.errors import ArgumentError, InputError
from tleaf_cli.logic.alphabet import ALPHABET_KINDS, Alphabet
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import parse
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.settings.meta import RUN_READOUTS


class Embedder:
    """q: formulas (as graphs), discrete traces and soft traces into one vector space."""

    def __init__(self, model: TripletEmbedder, vectors: GuardVectors, config: dict) -> None:
        self.model = model.eval()
        self.vectors = vectors
        self.config = config
        for p in self.model.parameters():
            p.requires_grad_(False)
        # every rule set embedded so far, by formula: its q(A_φ) is row k of `_kept_vectors`
        # and its one-hot letters' q_e vectors are `_kept_letters` rows offset.. offset + count
        # (row 0: zeros, the padding), on q's device: q is frozen, so a rule set's vectors
        # never change once computed, and a batch's are two gathers
        self._rule_sets: dict[str, tuple[int, int, int]] = {}  # formula -> (k, offset, count)
        self._kept_vectors: torch.Tensor | None = None
        self._kept_letters: torch.Tensor | None = None
        # (atoms k, device) -> the soft monitor walk of a one-hot alphabet of k atoms: it
        # depends on the number of atoms only (monitors read atoms by position)
        self._monitor_walks: dict[tuple[int, str], AlphabetWalk] = {}
        self._run_weights: dict[tuple, torch.Tensor] = {}  # DFA.structure -> [nodes, parts]

    @property
    def device(self) -> torch.device:
        """Where q's weights are (`Embedder.model.to(device)` moves them): q's inputs go there."""
        return next(self.model.parameters()).device

    @property
    def kind(self) -> str:
        return self.config["settings"]["embedder"]

    @property
    def recommended_lambda(self) -> float:
        """The tleaf loss's λ that fits this q (`settings.meta.recommended_lambda`): the loss term
        is then about 1 at q's own satisfy/violate boundary."""
        return float(self.config["recommended_lambda"])

    def embed_formula_rows(self, rows: Sequence[dict], batch: int = 256) -> torch.Tensor:
        """[len(rows), d] for compiled dfas.parquet rows: their DFA (q_m) or parse tree."""
        if self.kind == "dfa":  # a dfas.parquet's rows come back whole: share cache on
            return self.embed_dfas([dfa_from_row(r) for r in rows], batch, cache_shares=True)
        for r in rows:
            self.vectors.ids(r["atoms"])  # every atom must have features
        graphs = [syntax_graph(parse(r["formula"]), self.vectors.index) for r in rows]
        return self._encode(self.model.embed_formulas, graphs, batch)

    def embed_dfas(
        self, dfas: Sequence[DFA], batch: int = 256, cache_shares: bool = False
    ) -> torch.Tensor:
        """[len(dfas), d]: q_m of compiled DFAs (a q of kind `dfa`; the syntax baseline reads
        formula text, `embed_formula_rows`). `cache_shares`: keep the monitor shares of this
        DFA set on disk (`data.monitor_cache`), for sets that come back whole. The graphs are
        collated on the host (`meta_data.dfa_batch`), their readout weights kept per automaton
        (`_run_weights_of`)."""
        if self.kind != "dfa":
            raise InputError(f"a q of kind {self.kind!r} does not read DFAs")
        bank = self.model.trace.monitor_bank
        shares = None
        if bank is not None:  # for the whole set at once: its on-disk cache is per set
            shares = monitor_shares(dfas, bank, use_cache=cache_shares)
        encoder, device, parts = self.model.formula, self.device, []
        with torch.no_grad():
            for i in range(0, len(dfas), batch):
                part = dfa_batch(
                    dfas[i : i + batch],
                    self.vectors,
                    None if shares is None else shares[i : i + batch],
                )
                if encoder.readout in RUN_READOUTS:
                    part.run_weights = self._run_weights_of(dfas[i : i + batch], part)
                parts.append(self.model.embed_formulas(part.to(device)))
        return torch.cat(parts) if parts else torch.zeros((0, 0), device=device)

    def _run_weights_of(self, dfas: Sequence[DFA], batch) -> torch.Tensor:
        """[nodes, parts]: the readout weights (`AutomatonEncoder.run_weights`) of the graphs
        of `dfas` collated as `batch`, kept per automaton (they never read the atoms' names: a
        loss's fresh rule sets often repeat an automaton over other atoms), on the CPU; those
        of automata not kept yet computed for the whole batch in one call."""
        missing = [k for k, d in enumerate(dfas) if d.structure not in self._run_weights]
        if missing:
            weights = self.model.formula.run_weights(batch).t()
            ptr = batch.ptr.tolist()
            for k in missing:
                self._run_weights[dfas[k].structure] = weights[ptr[k] : ptr[k + 1]]
            if len(missing) == len(dfas):
                return weights
        return torch.cat([self._run_weights[d.structure] for d in dfas])

    def embed_traces(
        self,
        traces: Sequence[Sequence[Collection[str]]],
        atoms: Sequence[tuple[str, ...]],
        one_hot: bool | Sequence[bool] = False,
        batch: int = 256,
    ) -> torch.Tensor:
        """[len(traces), d] for discrete traces, trace i read over the atoms `atoms[i]` of a
        one-hot alphabet where `one_hot` (one bool for all, or one per trace; default:
        powerset)."""
        traces = arguments.traces(traces)
        atoms = arguments.sequence(atoms, "atoms", "atom tuples, one per trace")
        if len(atoms) != len(traces):
            raise ArgumentError("atoms", f"{len(atoms)} atom tuples for {len(traces)} traces")
        kinds = [one_hot] * len(traces) if isinstance(one_hot, bool) else one_hot
        device = self.device
        letters, monitors = trace_inputs(
            traces, atoms, kinds, self.vectors, self.model.trace.monitor_bank
        )
        with torch.no_grad():
            parts = [
                self.model.embed_traces(
                    chain_batch(
                        self.model.trace,
                        torch.cat(letters[i : i + batch]).to(device),
                        [len(x) for x in letters[i : i + batch]],
                        None if monitors is None else monitors[i : i + batch].to(device),
                    )
                )
                for i in range(0, len(letters), batch)
            ]
        return torch.cat(parts) if parts else torch.zeros((0, 0), device=device)

    def rule_set_vectors(self, rule_sets: Sequence[RuleSet]) -> tuple[torch.Tensor, torch.Tensor]:
        """q(A_φ) [R, d] and q_e of each rule set's one-hot letters (none, atoms[0], ...), padded
        with zero vectors to the most letters [R, L, d_e]; each rule set embedded once.

        The letters of all fresh rule sets go through q_e together and their DFAs through q_m
        together, so a batch full of new rule sets costs a few encoder calls, not a few per set.
        Raises InputError for atoms q's edge model never saw.
        """
        fresh = list({r.formula: r for r in rule_sets if r.formula not in self._rule_sets}.values())
        device = self.device
        if fresh:  # their letters' and guards' new q_e vectors in one q_e call
            counts = [len(r.atoms) + 1 for r in fresh]  # one-hot letters: none, each atom
            keys = [k for r in fresh for k in letter_keys(r.atoms, "one-hot")[1]]
            guards = [k for r in fresh for k in guard_keys(r.dfa)] if self.kind == "dfa" else []
            letters = self.vectors(keys + guards)[: len(keys)]  # the letters, set by set
            if self.kind == "dfa":
                vectors = self.embed_dfas([r.dfa for r in fresh])
            else:  # the syntax-tree baseline reads the formula's text
                rows = [{"formula": r.formula, "atoms": r.atoms} for r in fresh]
                vectors = self.embed_formula_rows(rows)
            self._keep(fresh, vectors.to(device), letters.to(device), counts)
        if self._kept_vectors.device != device:  # q moved since
            self._kept_vectors = self._kept_vectors.to(device)
            self._kept_letters = self._kept_letters.to(device)
        at = [self._rule_sets[r.formula] for r in rule_sets]
        width = max(count for _, _, count in at)
        index = np.zeros((len(at), width), dtype=np.int64)  # row 0: the zero padding
        for i, (_, offset, count) in enumerate(at):
            index[i, :count] = np.arange(offset, offset + count)
        tables = self._kept_letters.index_select(0, torch.from_numpy(index).view(-1).to(device))
        rows = torch.tensor([k for k, _, _ in at], device=device)
        return self._kept_vectors.index_select(0, rows), tables.view(len(at), width, -1)

    def _keep(
        self, fresh: list[RuleSet], vectors: torch.Tensor, letters: torch.Tensor, counts: list
    ) -> None:
        """Add rule sets `fresh` (their q(A_φ) `vectors` [F, d], their letters' q_e vectors
        `letters`, `counts` letters per set) to the kept rows."""
        if self._kept_vectors is None:
            self._kept_vectors = vectors[:0]
            self._kept_letters = letters.new_zeros(1, letters.shape[1])
        offset, first = len(self._kept_letters), len(self._kept_vectors)
        for k, (r, count) in enumerate(zip(fresh, counts, strict=True)):
            self._rule_sets[r.formula] = (first + k, offset, count)
            offset += count
        self._kept_vectors = torch.cat([self._kept_vectors, vectors])
        self._kept_letters = torch.cat([self._kept_letters, letters])

    def monitor_walks(self, rule_sets: Sequence[RuleSet]) -> list[AlphabetWalk] | None:
        """Each rule set's soft monitor walk over its one-hot letters (`AlphabetWalk`, what
        `soft_monitor_walk` reads), on q's device; built once per number of atoms (monitors
        read atoms by position) and kept. None for a q without monitors."""
        bank = self.model.trace.monitor_bank
        if bank is None:
            return None
        device = self.device
        walks = []
        for r in rule_sets:
            key = (len(r.atoms), str(device))
            if key not in self._monitor_walks:
                classes, present = monitor_classes(bank, one_hot_truth(len(r.atoms)))
                self._monitor_walks[key] = AlphabetWalk.of(bank, classes, present).to(device)
            walks.append(self._monitor_walks[key])
        return walks

    def _encode(self, encode, graphs, batch: int) -> torch.Tensor:
        device = self.device
        with torch.no_grad():
            parts = [
                encode(Batch.from_data_list(graphs[i : i + batch]).to(device))
                for i in range(0, len(graphs), batch)
            ]
        return torch.cat(parts) if parts else torch.zeros((0, 0), device=device)

    def letter_vectors(self, atoms: tuple[str, ...], domain: str) -> tuple[list, torch.Tensor]:
        """The letters over `atoms` (`letter_keys`) and their q_e vectors [letters, d]."""
        letters, keys = letter_keys(atoms, domain)
        return letters, self.vectors(keys)

    def embed_soft_traces(
        self,
        traces: Sequence[torch.Tensor],
        atoms: tuple[str, ...],
        columns: Sequence[str] | None = None,
        domain: str = "one-hot",
    ) -> torch.Tensor:
        """[B, d] vectors of soft traces, each [T_b, len(columns)] (per-step probabilities of the
        items `columns`, default `atoms`), over a formula's atoms."""
        atoms = tuple(arguments.sequence(atoms, "atoms", "atom names (str)"))
        columns = list(atoms) if columns is None else arguments.sequence(columns, "columns", "str")
        missing = [a for a in atoms if a not in columns]
        if missing:
            raise ArgumentError("columns", f"has no column for atom {missing[0]!r}")
        if domain not in ALPHABET_KINDS:
            raise ArgumentError(
                "domain", f"must be one of {', '.join(ALPHABET_KINDS)}, not {domain!r}"
            )
        traces = arguments.soft_traces(traces, len(columns))
        probs = torch.nn.utils.rnn.pad_sequence(
            [letter_probabilities(p, columns, atoms, domain) for p in traces],
            batch_first=True,
        )
        device = probs.device
        _, table = self.letter_vectors(atoms, domain)
        table = table.to(device)
        lengths = torch.tensor([p.shape[0] for p in traces], device=device)
        bank = self.model.trace.monitor_bank
        monitor = None
        if bank is not None:
            classes, present = monitor_classes(bank, Alphabet(tuple(atoms), domain).truth())
            n = len(traces)
            monitor = soft_monitor_features(
                bank, probs, lengths, classes.expand(n, -1, -1), present.expand(n, -1)
            )
        return soft_trace_vectors(self.model, probs @ table, lengths, monitor)

    def embed_soft_trace(self, probs: torch.Tensor, atoms, columns=None, domain="one-hot"):
        """The vector of one soft trace [T, len(columns)] (see `embed_soft_traces`)."""
        return self.embed_soft_traces([probs], tuple(atoms), columns, domain)[0]
