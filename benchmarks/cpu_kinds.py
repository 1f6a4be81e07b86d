"""Which of q's operations are slow on which kind of CPU: q_m's products on their real shapes,
and q_e's and q_m's epochs, with torch's own kernels (this CPU's) beside its AVX2 kernels.

    python benchmarks/cpu_kinds.py [--out out/bench-speed] [--formulas 300] [--batches 8]
                                   [--repeat 5] [--epochs 3] [--kinds native avx2]

A kind is a set of environment variables a fresh process starts with, so one machine runs the
kernels each kind of CPU would get: `native` none (torch, MKL and oneDNN pick this CPU's
widest vectors), `avx2` the kernels an AVX2-only CPU gets (`ATEN_CPU_CAPABILITY=avx2` for
torch's own operators, `MKL_ENABLE_INSTRUCTIONS=AVX2` for its dense and sparse BLAS,
`ONEDNN_MAX_CPU_ISA=AVX2`). That isolates the kernels' choice; an AVX2-only CPU also differs in
its caches and clocks, which no setting here reproduces.

The data are `benchmarks/speed.py`'s (SYNTHETIC: the Low tier, `--formulas` formulas with 20
traces each). q_m (preset best) trains one epoch here, keeping its first `--batches` batches'
GCN layers as the encoder called them (input, joint adjacency Â and its transpose, weights).
Each kind's process then times, one torch thread, per batch (all its layers) and forwards and
backwards, each of the ways one layer's products can be written:

* `dense X·Wᵀ`: the layer's dense products (forwards, and backwards the input's and weights'
  gradients), as `_GCNLayer` runs them;
* `dense X·Wᵀ numpy`: the same products by numpy on the same memory (its own BLAS, OpenBLAS in
  numpy's wheels, where torch's CPU wheels use MKL);
* `Â·S CSR`: the sparse products Â·S and Âᵀ·G as the layer runs them (`addmm` on CSR);
* `Â·S COO`: the same with Â as a COO matrix (`torch.sparse.mm`);
* `Â·S segment`: gather S's rows by Â's column, scale, `index_add_` into Â's rows;
* `Â·S dense`: Â as a dense matrix (`mm`);
* `gcn_layer`: the layer as q_m runs it, forwards and backwards (what the parts add to).

Then each kind trains q_e and q_m (`speed.py`'s commands, `--epochs` epochs, the mean of the
epochs after the first). The kinds take turns `--rounds` times; each figure is the median over
them. Prints the CPU, then two markdown tables with each kind's figure and its ratio to
`native`.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import speed

ROOT = Path(__file__).resolve().parents[1]
KINDS = {
    "native": {},
    "avx2": {
        "ATEN_CPU_CAPABILITY": "avx2",
        "MKL_ENABLE_INSTRUCTIONS": "AVX2",
        "ONEDNN_MAX_CPU_ISA": "AVX2",
    },
}
WAYS = (
    "dense X·Wᵀ",
    "dense X·Wᵀ numpy",
    "Â·S CSR",
    "Â·S COO",
    "Â·S segment",
    "Â·S dense",
    "gcn_layer",
)


def capture(data: Path, batches: int, out: Path) -> int:
    """Train q_m (preset best) one epoch on the Low tier with `speed.py`'s q_e; save the GCN
    layer calls of its first `batches` training batches to `out` (a list of dicts of tensors,
    the sparse matrices as their CSR parts). Returns how many layer calls a batch has."""
    import torch

    from tleaf_cli.embed import layers
    from tleaf_cli.embed.train_meta import MetaSettings, train_meta

    calls: list[dict] = []
    original = layers._GCNLayer.forward

    def forward(ctx, x, matrix, transposed, *weights_and_biases):
        if any(ctx.needs_input_grad):  # training (an evaluation's calls need no gradient)
            calls.append(
                {
                    "x": x.detach().clone(),
                    "matrix": _parts(matrix),
                    "transposed": _parts(transposed),
                    "weights": [w.detach().clone() for w in weights_and_biases],
                }
            )
        return original(ctx, x, matrix, transposed, *weights_and_biases)

    low = data / "low"
    edge = data / "runs" / "cpu-kinds-edge"
    if not (edge / "weights.pt").exists():
        speed.tleaf(ROOT, "train-edge", str(low / "dfas.parquet"), "-o", str(edge), "--epochs", "1")
    layers._GCNLayer.forward = staticmethod(forward)
    try:
        with tempfile.TemporaryDirectory(prefix="cpu-kinds-") as folder:
            settings = MetaSettings.preset("best", epochs=1)
            train_meta(
                low / "dfas.parquet", low / "traces.parquet", edge, Path(folder) / "m", settings
            )
    finally:
        layers._GCNLayer.forward = original
    # a batch's layers read one adjacency: count the calls on the first one
    per_batch = next(
        (i for i, c in enumerate(calls) if c["matrix"]["size"] != calls[0]["matrix"]["size"]),
        len(calls),
    )
    kept = calls[: batches * per_batch]
    torch.save(kept, out)
    return per_batch


def _parts(matrix) -> dict:
    """A CSR matrix's parts, which torch.save keeps whatever its sparse support."""
    return {
        "crow": matrix.crow_indices().clone(),
        "col": matrix.col_indices().clone(),
        "values": matrix.values().detach().clone(),
        "size": list(matrix.shape),
    }


def time_ways(calls_file: Path, per_batch: int, repeat: int) -> dict:
    """In this process (its kind's environment): seconds per batch of each way, and torch's
    CPU capability as it reports it."""
    import torch

    from tleaf_cli.embed.layers import _GCNLayer

    torch.set_num_threads(1)
    torch.manual_seed(0)
    calls = torch.load(calls_file, weights_only=True)
    timers = {way: [] for way in WAYS}
    for call in calls:
        for way, timer in zip(WAYS, _layer_timers(call, _GCNLayer), strict=True):
            timers[way].append(timer)
    seconds = {way: _per_call(timer_list, repeat) * per_batch for way, timer_list in timers.items()}
    return {
        "capability": torch.backends.cpu.get_cpu_capability(),
        "ms_per_batch": {way: s * 1e3 for way, s in seconds.items()},
    }


def _layer_timers(call: dict, layer) -> list[Callable[[], None]]:
    """One callable per way (WAYS' order) doing that way's products for one layer call,
    forwards and backwards, on the call's shapes."""
    import torch

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        csr, csr_t = (
            torch.sparse_csr_tensor(p["crow"], p["col"], p["values"], p["size"])
            for p in (call["matrix"], call["transposed"])
        )
        coo, coo_t = csr.to_sparse_coo().coalesce(), csr_t.to_sparse_coo().coalesce()
        dense, dense_t = csr.to_dense(), csr_t.to_dense()
    x, weights_and_biases = call["x"], call["weights"]
    ways_n = len(weights_and_biases) // 2
    weight = torch.cat(weights_and_biases[:ways_n])
    width = weights_and_biases[ways_n].shape[0]
    states = torch.randn(x.shape[0] * ways_n, width)
    grad = torch.randn(x.shape[0], width)
    grad_states = torch.randn(x.shape[0], ways_n * width)
    rows = torch.repeat_interleave(torch.arange(csr.shape[0]), csr.crow_indices().diff().long())
    cols, values = csr.col_indices().long(), csr.values()
    rows_t = torch.repeat_interleave(
        torch.arange(csr_t.shape[0]), csr_t.crow_indices().diff().long()
    )
    cols_t, values_t = csr_t.col_indices().long(), csr_t.values()

    def segment(r, c, v, s, n):
        out = s.new_zeros(n, s.shape[1])
        return out.index_add_(0, r, s.index_select(0, c) * v.unsqueeze(1))

    def dense_products() -> None:
        torch.mm(x, weight.t())
        torch.mm(grad_states, weight), torch.mm(grad_states.t(), x)

    xn, weight_n, grad_states_n = x.numpy(), weight.numpy(), grad_states.numpy()

    def numpy_products() -> None:
        xn @ weight_n.T
        grad_states_n @ weight_n, grad_states_n.T @ xn

    def csr_products() -> None:
        torch.addmm(grad, csr, states), torch.addmm(states, csr_t, grad, beta=0)

    def coo_products() -> None:
        torch.sparse.mm(coo, states), torch.sparse.mm(coo_t, grad)

    def segment_products() -> None:
        segment(rows, cols, values, states, csr.shape[0])
        segment(rows_t, cols_t, values_t, grad, csr_t.shape[0])

    def dense_adjacency() -> None:
        torch.mm(dense, states), torch.mm(dense_t, grad)

    params = [w.clone().requires_grad_() for w in weights_and_biases]
    x_in = x.clone().requires_grad_()

    def whole() -> None:
        out = layer.apply(x_in, csr, csr_t, *params)
        out.backward(grad)

    return [
        dense_products,
        numpy_products,
        csr_products,
        coo_products,
        segment_products,
        dense_adjacency,
        whole,
    ]


def _per_call(timers: list[Callable[[], None]], repeat: int) -> float:
    """Median over `repeat` rounds of the mean seconds of one call, after a warm-up round."""
    for timer in timers:
        timer()
    rounds = []
    for _ in range(repeat):
        start = time.perf_counter()
        for timer in timers:
            timer()
        rounds.append((time.perf_counter() - start) / len(timers))
    return sorted(rounds)[len(rounds) // 2]


def mkl_path(kind: str) -> str:
    """The code path MKL reports for a product in `kind`'s environment (MKL_VERBOSE's first
    line: on a CPU MKL does not take for Intel's it names no vector extension)."""
    env = {**os.environ, **KINDS[kind], "MKL_VERBOSE": "1", "OMP_NUM_THREADS": "1"}
    code = "import torch; torch.ones(64, 64) @ torch.ones(64, 64)"
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    line = next((t for t in done.stdout.splitlines() if t.startswith("MKL_VERBOSE oneMKL")), "")
    return line.partition(" for ")[2].split(", Lnx")[0] or "not reported"


def in_kind(kind: str, *args: str) -> dict:
    """This script with `args` in a fresh process in `kind`'s environment; its JSON answer."""
    env = {**os.environ, **KINDS[kind], "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    command = [sys.executable, __file__, *args]
    done = subprocess.run(command, env=env, cwd=ROOT, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def epochs_in_kind(kind: str, data: Path, epochs: int) -> dict[str, float]:
    """q_e's and q_m's seconds per epoch (`speed.measure`) in `kind`'s environment."""
    saved = dict(os.environ)
    os.environ.update(KINDS[kind])
    try:
        return speed.measure(ROOT, f"kind-{kind}", data, "cpu", epochs, recognisers=False)
    finally:
        os.environ.clear()
        os.environ.update(saved)


def _medians(answers: list[dict[str, float]]) -> dict[str, float]:
    """Each figure's median over the rounds."""
    return {key: statistics.median(a[key] for a in answers) for key in answers[0]}


def table(rows: dict[str, dict[str, float]], kinds: list[str], unit: str) -> str:
    """A markdown table: one row per figure, each kind's value and its ratio to the first."""
    head = f"| {unit} | " + " | ".join(kinds)
    head += "".join(f" | {k} / {kinds[0]}" for k in kinds[1:]) + " |"
    lines = [head, "|---" * (1 + 2 * len(kinds) - 1) + "|"]
    for name in rows[kinds[0]]:
        values = [rows[k][name] for k in kinds]
        ratios = [f"{v / values[0]:.2f}×" for v in values[1:]]
        lines.append(
            f"| {name} | " + " | ".join(f"{v:.3f}" for v in values)
            + "".join(f" | {r}" for r in ratios) + " |"
        )  # fmt: skip
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "bench-speed")
    parser.add_argument("--formulas", type=int, default=300, help="Low-tier formulas")
    parser.add_argument("--batches", type=int, default=8, help="q_m batches whose layers are timed")
    parser.add_argument("--repeat", type=int, default=5, help="rounds over the layers (median)")
    parser.add_argument("--epochs", type=int, default=3, help="epochs of q_e and q_m (0: none)")
    parser.add_argument("--rounds", type=int, default=3, help="turns of the kinds (median)")
    parser.add_argument("--kinds", nargs="+", default=list(KINDS), choices=list(KINDS))
    parser.add_argument("--time-ways", nargs=2, metavar=("CALLS", "PER_BATCH"), help="internal")
    args = parser.parse_args()
    if args.time_ways:  # a kind's process: time the saved calls, answer in JSON
        print(json.dumps(time_ways(Path(args.time_ways[0]), int(args.time_ways[1]), args.repeat)))
        return
    import op_count

    print(op_count.cpu_description(), flush=True)
    data = args.out.resolve() / "data"
    speed.prepare(data, ROOT, args.formulas)
    calls = args.out.resolve() / "cpu-kinds-calls.pt"
    per_batch = capture(data, args.batches, calls)
    seen: dict[str, list[dict]] = {kind: [] for kind in args.kinds}
    runs: dict[str, list[dict]] = {kind: [] for kind in args.kinds}
    for kind in args.kinds:
        print(kind, "MKL:", mkl_path(kind), flush=True)
    for _ in range(args.rounds):  # the kinds take turns: a drift of the host's speed hits both
        for kind in args.kinds:
            answer = in_kind(kind, "--time-ways", str(calls), str(per_batch), "--repeat",
                             str(args.repeat))  # fmt: skip
            print(kind, json.dumps(answer), flush=True)
            seen[kind].append(answer["ms_per_batch"])
        for kind in args.kinds if args.epochs else ():
            runs[kind].append(epochs_in_kind(kind, data, args.epochs))
            print(kind, json.dumps(runs[kind][-1]), flush=True)
    products = {kind: _medians(seen[kind]) for kind in args.kinds}
    epochs = {kind: _medians(runs[kind]) for kind in args.kinds if runs[kind]}
    print(table(products, args.kinds, "ms per q_m batch (its GCN layers)"))
    if epochs:
        print(table(epochs, args.kinds, "seconds per epoch"))


if __name__ == "__main__":
    main()
