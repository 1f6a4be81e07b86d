"""The arithmetic floor of q_m's training epoch: how long its matrix products alone take.

    python benchmarks/meta_products.py [--data out/bench-speed/data] [--batches 20]

Reads the Low tier and the q_e that `benchmarks/speed.py` prepares and trains (SYNTHETIC data,
`runs/this-cpu/edge`). Trains q_m (preset best) for one epoch, keeping its first `--batches`
training batches (formula DFAs and trace chains joined, as the encoder reads them) and counting
the epoch's batches; then, on those batches, one torch thread, prints per batch and scaled to the
epoch:

* the epoch as the run timed it (training only, its first epoch);
* the encoder (`AutomatonEncoder`) forwards and backwards, all of it;
* only its matrix products, on the same shapes: per GCN layer and direction the dense product
  X·W and the sparse Â·(XW) forwards, and backwards Âᵀ·G, the weight gradient Xᵀ·(ÂᵀG) and
  (after the first layer) the input gradient; the head's three products.

No epoch of this q can be faster than the last figure in float32 on this core, whatever the
rest of the step costs.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import torch

from tleaf_cli.embed.batches import join
from tleaf_cli.embed.graphs import gcn_adjacency
from tleaf_cli.embed.model import TripletEmbedder
from tleaf_cli.embed.train_meta import MetaSettings, train_meta

ROOT = Path(__file__).resolve().parents[1]


def capture(data: Path, keep: int) -> tuple[torch.nn.Module, list, int, float]:
    """Train q_m one epoch; its encoder, its first `keep` training batches (joined), how many
    batches the epoch has, and the epoch's training seconds."""
    kept, seen, encoder = [], [0], []
    original = TripletEmbedder.embed_both

    def embed_both(self, formulas, traces):
        if self.training:
            seen[0] += 1
            if len(kept) < keep:
                kept.append(join(formulas, traces))
                encoder[:] = [self.trace]
        return original(self, formulas, traces)

    TripletEmbedder.embed_both = embed_both
    out = Path(tempfile.mkdtemp(prefix="meta-products-"))
    try:
        low = data / "low"
        metrics = train_meta(
            low / "dfas.parquet",
            low / "traces.parquet",
            data / "runs" / "this-cpu" / "edge",
            out / "meta",
            MetaSettings.preset("best", epochs=1),
        )
    finally:
        TripletEmbedder.embed_both = original
        shutil.rmtree(out, ignore_errors=True)
    return encoder[0], kept, seen[0], metrics["history"][0]["seconds"]


def products(encoder: torch.nn.Module, batch) -> Callable[[], None]:
    """The matrix products of one forward and backward pass of `encoder` over `batch`, on random
    values of the same shapes (their time does not depend on the values)."""
    n, graphs = int(batch.num_nodes), int(batch.ptr.numel() - 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        along = gcn_adjacency(batch.edge_index, n)
        against = gcn_adjacency(batch.edge_index.flip(0), n)
    directions = (along, against) if encoder.back is not None else (along,)
    weights = [conv.lin.weight.detach().t().contiguous() for conv in encoder.convs]
    inputs = [torch.randn(n, w.shape[0]) for w in weights]
    grad = torch.randn(n, weights[0].shape[1])
    head = encoder.head.weight.detach().t().contiguous()
    pooled, head_grad = torch.randn(graphs, head.shape[0]), torch.randn(graphs, head.shape[1])

    def call() -> None:
        for layer, (x, w) in enumerate(zip(inputs, weights, strict=True)):
            for adjacency in directions:
                adjacency.matrix @ (x @ w)  # forwards
                g = adjacency.transposed @ grad  # backwards: through Â, then W's gradient
                x.t() @ g
                if layer:  # the first layer's input needs no gradient
                    g @ w.t()
        pooled @ head, pooled.t() @ head_grad, head_grad @ head.t()

    return call


def per_batch(calls: list[Callable[[], None]], repeat: int) -> float:
    """Mean seconds of one call over the batches, after one warm-up round."""
    for call in calls:
        call()
    start = time.perf_counter()
    for _ in range(repeat):
        for call in calls:
            call()
    return (time.perf_counter() - start) / repeat / len(calls)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=ROOT / "out/bench-speed/data")
    parser.add_argument("--batches", type=int, default=20, help="batches kept and timed")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(0)
    encoder, batches, epoch, seconds = capture(args.data, args.batches)
    nodes = sum(int(b.num_nodes) for b in batches) / len(batches)
    print(f"{epoch} batches an epoch; {len(batches)} timed, {nodes:.0f} nodes each on average")
    print(f"{'the epoch, all of it':32s} {seconds / epoch * 1e3:7.2f} ms a batch, {seconds:6.2f} s")

    def whole(batch) -> Callable[[], None]:
        def call() -> None:
            encoder.zero_grad()
            encoder(batch).sum().backward()

        return call

    encoder.train()
    rows = {
        "encoder forwards and backwards": per_batch([whole(b) for b in batches], args.repeat),
        "its matrix products only": per_batch([products(encoder, b) for b in batches], args.repeat),
    }
    for name, seconds in rows.items():
        print(f"{name:32s} {seconds * 1e3:7.2f} ms a batch, {seconds * epoch:6.2f} s an epoch")


if __name__ == "__main__":
    main()
