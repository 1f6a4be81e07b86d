"""Training the meta embedder q_m, or the syntax-tree baseline (`tleaf train-meta`).

Read top to bottom: settings, data, model, the shared triplet loop, the test score, the model
directory. A triplet is (formula, satisfying trace, violating trace) of the traces' train split;
each epoch pairs every satisfying trace with a random violating trace of the same formula (the
paper samples pairs per formula). The val split's fixed pairs choose the best epoch; the test
split, formulas never trained on, gives the final triplet accuracy, also per kind of violating
trace (uniform / hard).

`embedder="dfa"` (T-LEAF): formulas are expanded DFA graphs and traces chains, both through one
AutomatonEncoder whose edge nodes carry the frozen q_e's vectors. `embedder="syntax"` (the
paper's baseline): formulas are parse trees through a SyntaxEncoder; traces as before.
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from tleaf_cli.data.artifacts import describe_inputs, relative_to, write_text_atomic
from tleaf_cli.data.dfa_table import dfa_from_row, read_dfas
from tleaf_cli.data.traces import read_traces
from tleaf_cli.embed.automaton import AutomatonEncoder
from tleaf_cli.embed.batches import GraphStore, JointStore
from tleaf_cli.embed.graphs import syntax_graph
from tleaf_cli.embed.load import load_edge_model
from tleaf_cli.embed.meta_data import (
    GuardVectors,
    chain_batch,
    featured_dfa_graphs,
    trace_inputs,
    with_chain_templates,
)
from tleaf_cli.embed.model import TripletEmbedder, build_model, store_run_weights
from tleaf_cli.embed.triplets import (
    SCORE,
    EpochReport,
    anchor_pull,
    reporting,
    triplet_accuracy,
    triplet_step,
)
from tleaf_cli.errors import InputError, MissingSplitError
from tleaf_cli.logic.formulas import parse
from tleaf_cli.settings import check_values
from tleaf_cli.settings.meta import (
    RUN_READOUTS,
    SETTINGS_VERSION,
    MetaSettings,
    recommended_lambda,
)
from tleaf_cli.training.loop import LoopSettings, Step, chunks, device_for, fit

GROUP = 4  # triplets of one formula that share its embedding within a batch
SCORE_BATCH = 512  # pairs per pass when scoring (no gradient: a graph's vector is its own)


def train_meta(
    dfas_path: str | Path,
    traces_path: str | Path,
    edge_dir: str | Path,
    out_dir: str | Path,
    settings: MetaSettings,
    resume: bool = False,
    on_epoch: Callable[[EpochReport], None] | None = None,
) -> dict:
    out_dir = Path(out_dir)
    check_values(settings)
    torch.manual_seed(settings.seed)
    device = device_for(settings.device)

    # ---- data: formula graphs, trace graphs, and which traces go with which formula
    edge_model, edge_config = load_edge_model(edge_dir)
    vectors = GuardVectors(edge_model, edge_config["vocabulary"])
    vocab_index = {a: i for i, a in enumerate(edge_config["vocabulary"])}
    rows = {r["formula_id"]: r for r in read_dfas(dfas_path).rows if r["error"] is None}
    traces = read_traces(traces_path)
    # the automatic choices (monitor slots, evidence, sphere) made for these formulas
    settings = settings.resolved(max((len(r["atoms"]) for r in rows.values()), default=0))
    loop = LoopSettings.of(settings)
    model = build_model(settings, vectors.dim, edge_model.atom_table)
    monitors = model.trace.monitor_bank
    if "split" not in traces.column_names:
        raise MissingSplitError(traces_path)
    if settings.embedder == "dfa":  # in one call: one q_e batch, the monitor shares cached
        dfas = [dfa_from_row(row) for row in rows.values()]
        graphs = featured_dfa_graphs(dfas, vectors, monitors, cache_shares=True)
        formula_graphs = dict(zip(rows, graphs, strict=True))
    else:
        formula_graphs = {}
        for fid, row in rows.items():
            vectors.ids(row["atoms"])  # every atom must have features
            formula_graphs[fid] = syntax_graph(parse(row["formula"]), vocab_index)
    formula_index = {fid: i for i, fid in enumerate(formula_graphs)}  # its graph in `store`
    by_split: dict[str, dict[str, dict[bool, list]]] = defaultdict(
        lambda: defaultdict(lambda: {True: [], False: []})
    )
    kept = [t for t in traces.to_pylist() if t["formula_id"] in rows]
    # a trace is its letters' q_e vectors [T, d] (`embed` batches them as chains), with its
    # monitor features where q reads them
    letters, monitor = trace_inputs(
        [t["trace"] for t in kept],
        [tuple(rows[t["formula_id"]]["atoms"]) for t in kept],
        [rows[t["formula_id"]]["alphabet"] == "one-hot" for t in kept],
        vectors,
        monitors,
    )
    for k, t in enumerate(kept):  # a trace is its index k in `letters` and `monitor`
        by_split[t["split"]][t["formula_id"]][t["label"]].append((k, t["source"]))

    def fixed_pairs(split: str, source: str | None = None):
        out = []
        for fid, sides in by_split[split].items():
            for (sat, _), (neg, kind) in zip(sides[True], sides[False], strict=False):
                if source is None or kind == source:
                    out.append((formula_index[fid], sat, neg))
        return out

    train_formulas = [f for f, s in by_split["train"].items() if s[True] and s[False]]
    if not train_formulas or not fixed_pairs("val"):
        raise InputError(f"{traces_path}: needs satisfying and violating traces in train and val")

    # ---- model and the shared triplet loop
    if settings.readout in RUN_READOUTS and settings.embedder == "dfa":
        store_run_weights(model.trace, list(formula_graphs.values()))  # once per graph
    model = model.to(device)
    # the formula graphs collated once, on the device; a batch selects its formulas by index.
    # With q_m's own encoder (one for both), the store also holds a trace chain of every
    # length and the matrices the encoder reads (adjacency, readout pool), built once: a
    # batch of formulas and traces is then one select, its matrices gathered, not rebuilt
    chain_of: dict[int, int] = {}
    # (q_m's encoder with run readouts and no probes: a JointStore, which also holds every
    # trace's letters and monitor features, so that a batch is index arithmetic on the host
    # and a few gathers on the device)
    joined = settings.embedder == "dfa" and isinstance(model.trace, AutomatonEncoder)
    if joined:
        graphs, chain_of = with_chain_templates(
            model.trace, list(formula_graphs.values()), {len(x) for x in letters}
        )
        if settings.readout in RUN_READOUTS and not settings.probes:
            store = JointStore(
                graphs,
                chain_of,
                model.trace.node_inputs,
                model.trace.block_matrices,
                letters,
                None if monitor is None else monitor[:, : model.trace.monitor_width],
                device,
                _evidence_units(model, list(formula_graphs.values()), letters, monitor, device),
            )
        else:
            store = GraphStore(graphs, device, model.trace.block_matrices)
    else:
        store = GraphStore(list(formula_graphs.values()), device)

    def epoch_triplets(epoch: int, generator: torch.Generator):
        # Triplets travel in groups of GROUP from one formula, the groups shuffled: a batch still
        # mixes many formulas, and each formula graph is embedded once per group, not per triplet.
        groups = []
        for fid in train_formulas:
            sides = by_split["train"][fid]
            picks = torch.randint(len(sides[False]), (len(sides[True]),), generator=generator)
            triplets = [
                (formula_index[fid], sat, sides[False][k][0])
                for (sat, _), k in zip(sides[True], picks.tolist(), strict=True)
            ]
            groups += [triplets[i : i + GROUP] for i in range(0, len(triplets), GROUP)]
        for chunk in chunks(groups, max(1, settings.batch_size // GROUP), generator):
            yield [t for group in chunk for t in group]

    def embed(chunk):
        formulas, sats, negs = zip(*chunk, strict=True)
        distinct = list(dict.fromkeys(formulas))  # each formula embedded once per batch
        row = {key: i for i, key in enumerate(distinct)}
        traces = sats + negs  # one batch of chains for both sides
        if isinstance(store, JointStore):
            z_formulas, z_traces = model.embed_joined(store.select(distinct, traces), len(distinct))
        else:
            z_formulas, z_traces = embed_batches(distinct, traces)
        anchors = torch.from_numpy(np.array([row[f] for f in formulas], dtype=np.int64))
        return (
            z_formulas.index_select(0, anchors.to(device)),
            z_traces[: len(sats)],
            z_traces[len(sats) :],
        )

    def embed_batches(distinct, traces):
        """The formulas `distinct` and the traces (indices) as graph batches: one select from
        the store of the formulas and the traces' chain templates, the letters on the chains'
        edge nodes (in trace and step order, as `chain_batch` puts them) and the traces'
        monitor features in their chains' rows (q_m's own encoder); else the formulas
        selected and the chains built."""
        rows = None if monitor is None else monitor[list(traces)].to(device)
        steps = torch.cat([letters[k] for k in traces]).to(device)
        if not joined:
            chains = chain_batch(model.trace, steps, [len(letters[k]) for k in traces], rows)
            return model.embed_both(store.select(distinct), chains)
        batch = store.select(distinct + [chain_of[len(letters[k])] for k in traces])
        on_letters = (batch.letter >= 0).nonzero().flatten()
        batch.edge_vec = batch.edge_vec.index_copy(0, on_letters, steps)
        if rows is not None:
            batch.monitor = torch.cat([batch.monitor[: len(distinct)], rows])
        return model.embed_joined(batch, len(distinct))

    def scores(pairs) -> dict[str, float]:
        """Triplet accuracy over `pairs`, and the mean squared distance of the formula to its
        satisfying and to its violating traces (one embedding pass)."""
        sums = torch.zeros(3, dtype=torch.float64)
        for i in range(0, len(pairs), SCORE_BATCH):
            part = pairs[i : i + SCORE_BATCH]
            anchor, pos, neg = embed(part)
            distance = [(anchor - z).pow(2).sum(dim=1).sum().item() for z in (pos, neg)]
            hits = triplet_accuracy(anchor, pos, neg) * len(part)
            sums += torch.tensor([hits, *distance], dtype=torch.float64)
        accuracy, satisfying, violating = (sums / max(len(pairs), 1)).tolist()
        return {
            "accuracy": accuracy,
            "satisfying_distance": satisfying,
            "violating_distance": violating,
        }

    def extra_loss(triplet) -> torch.Tensor:
        loss = anchor_pull(triplet[0], triplet[1]) * settings.pull
        if settings.radius_weight:
            loss = loss + settings.radius_weight * model.radius.loss(*triplet)
        return loss

    val = fixed_pairs("val")
    metrics = fit(
        model,
        epoch_triplets,
        joint_step(model, store, settings)
        if isinstance(store, JointStore) and settings.distance == "squared"
        else triplet_step(
            embed,
            settings.margin,
            extra_loss if settings.pull or settings.radius_weight else None,
            settings.distance,
        ),
        lambda: scores(val)["accuracy"],
        loop,
        out_dir,
        score=SCORE,
        resume=resume,
        on_epoch=reporting(on_epoch),
        flat=isinstance(store, JointStore),  # every parameter of q_m is read in every step
    )

    # ---- test split with the best weights (the model leaves the loop with them)
    model.eval()
    with torch.no_grad():
        test = fixed_pairs("test")
        figures = scores(test)
        metrics["test"] = {
            "triplet_accuracy": figures["accuracy"],
            "uniform_negatives": scores(fixed_pairs("test", "uniform"))["accuracy"],
            "hard_negatives": scores(fixed_pairs("test", "hard"))["accuracy"],
            "pairs": len(test),
            "satisfying_distance": figures["satisfying_distance"],
            "violating_distance": figures["violating_distance"],
        }
        # q's own satisfy/violate boundary, on val: what the tleaf loss's λ is measured against
        figures = scores(val)
        metrics["val"] = {
            "triplet_accuracy": figures["accuracy"],
            "satisfying_distance": figures["satisfying_distance"],
            "violating_distance": figures["violating_distance"],
        }

    # ---- the model directory
    config = {
        "kind": "meta-embedder",
        "settings_version": SETTINGS_VERSION,
        "settings": asdict(settings),
        "recommended_lambda": recommended_lambda(metrics["val"]),
        # both: relative to this folder, so that moving a whole tree (out/...) keeps it loadable,
        # and absolute, so that this folder copied alone still finds its edge model
        "edge_model": str(Path(edge_dir).resolve()),
        "edge_model_relative": relative_to(out_dir, edge_dir),
        "edge_config": edge_config,
        "inputs": describe_inputs([dfas_path, traces_path]),
    }
    write_text_atomic(out_dir / "config.json", json.dumps(config, indent=2))
    write_text_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2))
    return metrics


def joint_step(
    model: TripletEmbedder, store: JointStore, settings: MetaSettings
) -> Callable[[list], Step]:
    """`triplet_step`'s step for a JointStore's batches of triplets (formula index, satisfying
    trace index, violating trace index) and squared distances: each triplet's two distances
    computed once and read by every term (the triplet loss, the pull, the radius loss, the
    accuracy), the terms added in `triplet_step`'s order."""

    def step(chunk) -> Step:
        formulas, sats, negs = zip(*chunk, strict=True)
        distinct = list(dict.fromkeys(formulas))
        row = {key: i for i, key in enumerate(distinct)}
        z = model.joint_vectors(store.select(distinct, sats + negs), len(distinct))
        anchors = np.array([row[f] for f in formulas] * 2, dtype=np.int64)
        anchor = z.index_select(0, store.on_device(anchors))
        # positive pairs, then negative pairs
        distances = (anchor - z[len(distinct) :]).pow(2).sum(dim=1)
        d_pos, d_neg = distances[: len(chunk)], distances[len(chunk) :]
        loss = torch.relu(d_pos - d_neg + settings.margin).mean()
        if settings.pull or settings.radius_weight:
            extra = d_pos.mean() * settings.pull if settings.pull else None
            if settings.radius_weight:
                radius = settings.radius_weight * model.radius.loss_of_distances(distances)
                extra = radius if extra is None else extra + radius
            loss = loss + extra
        accuracy = float((d_pos < d_neg).float().mean())
        return Step(loss, {"loss": loss.item(), "train_accuracy": accuracy}, len(chunk))

    return step


def _evidence_units(model, formula_graphs, letters, monitor, device):
    """The evidence block's unit vectors of every formula and every trace (constants: they read
    the monitor features alone), or None where q has no block."""
    if model.evidence is None:
        return None
    width = model.trace.monitor_width
    formulas = torch.cat([g.monitor for g in formula_graphs])[:, :width].float()
    lengths = torch.tensor([len(x) for x in letters])
    with torch.no_grad():
        return (
            model.evidence.formula_units(formulas.to(device)),
            model.evidence.trace_units(monitor[:, :width].to(device), lengths.to(device)),
        )
