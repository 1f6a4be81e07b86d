"""Milliseconds of the logic losses and of the tleaf loss's parts on one batch, forwards and
backwards, one torch thread: where a training step's loss time goes.

    python benchmarks/loss_parts.py [--data out/bench-speed/data/ar] [--steps 12]

Reads the action-recognition data and q that `benchmarks/speed.py` prepares (SYNTHETIC
activities, a q trained one epoch on their rule sets). The batch: 16 videos of `--steps` steps
(lengths drawn from steps/2 to steps), random outputs, and the 16 rule sets of `--atoms` (3-10)
drawn knowledge-base atoms, as the model's predictions would bring up, each already embedded
(as after its first batch). Prints, per part, the mean over `--repeat` calls after 5 warm-up calls:

* the soft monitor walk (`soft_monitor_walk`: every monitor's state distribution over the
  soft trace) and q_m over the soft trace chains (`soft_trace_vectors`), each alone;
* `tleaf_loss` (both, and the expected letter vectors);
* `logic_loss("tleaf" | "exact")` whole, from the vocabulary's log-probabilities;
* `rule_set_vectors` of fresh rule sets, `--fresh` a batch (q_e of their new guards, their
  DFA graphs, monitor shares and q_m), after 300 others were embedded.
"""

from __future__ import annotations

import argparse
import random
import time
from collections.abc import Callable
from pathlib import Path

import torch

from tleaf_cli.embed.load import load_embedder
from tleaf_cli.embed.soft_monitors import soft_monitor_walk
from tleaf_cli.embed.soft_traces import soft_trace_vectors
from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import logic_loss, pair_log_probs, pair_vocabulary
from tleaf_cli.losses.packed import letter_log_probs, pack_rows
from tleaf_cli.losses.tleaf import tleaf_loss
from tleaf_cli.tasks.action_recognition.activities import read_activities

ROOT = Path(__file__).resolve().parents[1]


def milliseconds(call: Callable[[], object], repeat: int) -> float:
    for _ in range(5):
        call()
    start = time.perf_counter()
    for _ in range(repeat):
        call()
    return (time.perf_counter() - start) / repeat * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=ROOT / "out/bench-speed/data/ar")
    parser.add_argument("--steps", type=int, default=12, help="steps per video")
    parser.add_argument("--repeat", type=int, default=50)
    parser.add_argument("--fresh", type=int, default=12, help="fresh rule sets per batch")
    parser.add_argument("--atoms", default="3-10", help="knowledge-base atoms drawn per rule set")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(args.seed)

    data = read_activities(args.data / "activities.parquet")
    kb = read_knowledge_base(args.data / "kb.ltl")
    vocabulary = pair_vocabulary(data.actions, data.ingredients)
    rules = KnowledgeRuleSets(kb, vocabulary)
    rules.prepare()
    q = load_embedder(args.data / "meta")
    rng = random.Random(args.seed)
    atoms = sorted({a for r in kb for a in r.atoms})
    low, high = (int(x) for x in args.atoms.split("-"))
    drawn = [set(rng.sample(atoms, rng.randint(low, high))) for _ in range(1500)]
    sets = list({g[0].formula: g[0] for g in rules.for_atoms(drawn) if g}.values())
    batch, fresh = sets[:16], sets[16:]

    n, t = len(batch), args.steps
    actions = torch.randn(n, t, len(data.actions), requires_grad=True)
    ingredients = torch.randn(n, t, len(data.ingredients), requires_grad=True)
    lengths = torch.randint(t // 2, t + 1, (n,))
    packed, rows = pack_rows(batch, len(vocabulary), actions.device)
    letters = letter_log_probs(pair_log_probs(actions, ingredients), packed, rows)
    letters = letters.detach().requires_grad_()
    probs = letters.exp().detach().requires_grad_()
    walks = q.monitor_walks(packed.rule_sets)
    walks = [walks[r] for r in rows.tolist()]
    bank = q.model.trace.monitor_bank
    monitor = soft_monitor_walk(bank, probs, lengths, walks).detach()
    _, table = q.rule_set_vectors(packed.rule_sets)
    expected = torch.bmm(probs, table[rows][:, : letters.shape[-1]]).detach().requires_grad_()

    def whole(kind: str) -> Callable[[], None]:
        def call() -> None:
            log_probs = pair_log_probs(actions, ingredients)
            logic_loss(kind, log_probs, batch, lengths, embedder=q).backward()

        return call

    atoms_of = [len(r.atoms) for r in batch]
    slots = sum(w.slots for w in walks)
    print(f"16 rule sets of {min(atoms_of)}-{max(atoms_of)} atoms, {t} steps, {slots} slots")
    parts = {
        "soft monitor walk": lambda: (
            soft_monitor_walk(bank, probs, lengths, walks).sum().backward()
        ),
        "q_m over the soft trace chains": lambda: (
            soft_trace_vectors(q.model, expected, lengths, monitor).sum().backward()
        ),
        "tleaf_loss": lambda: tleaf_loss(letters, lengths, packed, rows, q).sum().backward(),
        "logic_loss tleaf, whole": whole("tleaf"),
        "logic_loss exact, whole": whole("exact"),
    }
    for name, call in parts.items():
        print(f"{name:34s} {milliseconds(call, args.repeat):8.2f} ms forwards and backwards")
    q.rule_set_vectors(fresh[:300])
    later = fresh[300:]
    chunks = [later[i : i + args.fresh] for i in range(0, len(later) - args.fresh, args.fresh)]
    start = time.perf_counter()
    for chunk in chunks[:40]:
        q.rule_set_vectors(chunk)
    each = (time.perf_counter() - start) / len(chunks[:40]) * 1e3
    print(f"{'rule_set_vectors, ' + str(args.fresh) + ' fresh':34s} {each:8.2f} ms")


if __name__ == "__main__":
    main()
