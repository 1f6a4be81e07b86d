"""The triplet-training loop shared by the edge and meta embedders.

One epoch: the model embeds batches of (anchor, positive, negative), the triplet loss is
minimised with Adam, then `evaluate()` scores held-out data. The best epoch's weights go to
`weights.pt`; every epoch also writes `checkpoint.pt` (model, optimiser, history, RNG) so that
`resume=True` continues where a run stopped. Stops after `epochs`, after `patience` epochs
without a better score, or after the epoch that passes `max_minutes`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import torch

from tleaf_cli.embed.encoders import triplet_accuracy, triplet_loss

Triplet = tuple[torch.Tensor, torch.Tensor, torch.Tensor]
SCHEDULES = ("constant", "cosine")


@dataclass
class EpochReport:
    epoch: int
    loss: float
    train_accuracy: float
    heldout_accuracy: float
    seconds: float


@dataclass(frozen=True)
class LoopSettings:
    epochs: int
    patience: int
    margin: float
    lr: float
    seed: int
    max_minutes: float | None = None
    schedule: str = "constant"  # or "cosine": the learning rate falls to 0 over `epochs`

    @classmethod
    def of(cls, settings: object) -> LoopSettings:
        """The loop's fields, taken from a trainer's settings object (defaults where it has
        none)."""
        return cls(
            **{f.name: getattr(settings, f.name) for f in fields(cls) if hasattr(settings, f.name)}
        )


def fit(
    model: torch.nn.Module,
    batches: Callable[[torch.Generator], Iterable[object]],
    embed: Callable[[object], Triplet],
    evaluate: Callable[[], float],
    settings: LoopSettings,
    out_dir: Path,
    resume: bool = False,
    on_epoch: Callable[[EpochReport], None] | None = None,
    extra_loss: Callable[[Triplet], torch.Tensor] | None = None,
) -> dict:
    """Train `model` (its state_dict is what is saved); returns {"best", "history"}.

    `extra_loss`, when given, is added to the triplet loss of every batch."""
    start = time.perf_counter()
    optimiser = torch.optim.Adam([p for p in model.parameters() if p.requires_grad], lr=settings.lr)
    if settings.schedule not in SCHEDULES:
        raise ValueError(f"schedule must be one of {SCHEDULES}, not {settings.schedule!r}")
    # cosine: stepped once per epoch, so a resumed run continues on the same curve
    scheduler = (
        torch.optim.lr_scheduler.CosineAnnealingLR(optimiser, T_max=settings.epochs)
        if settings.schedule == "cosine"
        else None
    )
    history: list[dict] = []
    best = {"heldout_accuracy": -1.0, "epoch": 0}
    first = 1
    checkpoint = out_dir / "checkpoint.pt"
    if resume and checkpoint.exists():
        state = torch.load(checkpoint, weights_only=False)
        model.load_state_dict(state["model"])
        optimiser.load_state_dict(state["optimiser"])
        if scheduler is not None and "scheduler" in state:
            scheduler.load_state_dict(state["scheduler"])
        history, best, first = state["history"], state["best"], state["epoch"] + 1
        torch.set_rng_state(state["torch_rng"])
    out_dir.mkdir(parents=True, exist_ok=True)

    stale = 0
    for epoch in range(first, settings.epochs + 1):
        generator = torch.Generator().manual_seed(settings.seed * 100_003 + epoch)
        model.train()
        loss_sum = acc_sum = 0.0
        seen = 0
        for batch in batches(generator):
            anchor, pos, neg = embed(batch)
            loss = triplet_loss(anchor, pos, neg, settings.margin)
            if extra_loss is not None:
                loss = loss + extra_loss((anchor, pos, neg))
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            n = anchor.shape[0]
            loss_sum += loss.item() * n
            acc_sum += triplet_accuracy(anchor.detach(), pos.detach(), neg.detach()) * n
            seen += n
        if scheduler is not None:
            scheduler.step()
        model.eval()
        with torch.no_grad():
            score = evaluate()
        report = EpochReport(
            epoch,
            loss_sum / max(seen, 1),
            acc_sum / max(seen, 1),
            score,
            time.perf_counter() - start,
        )
        history.append(asdict(report))
        if score > best["heldout_accuracy"]:
            best = {"heldout_accuracy": score, "epoch": epoch}
            torch.save(model.state_dict(), out_dir / "weights.pt")
            stale = 0
        else:
            stale += 1
        torch.save(
            {
                "model": model.state_dict(),
                "optimiser": optimiser.state_dict(),
                "scheduler": scheduler.state_dict() if scheduler is not None else None,
                "epoch": epoch,
                "history": history,
                "best": best,
                "torch_rng": torch.get_rng_state(),
            },
            checkpoint,
        )
        if on_epoch:
            on_epoch(report)
        over_budget = settings.max_minutes is not None and (
            time.perf_counter() - start > 60 * settings.max_minutes
        )
        if stale >= settings.patience or over_budget:
            break
    return {"best": best, "history": history}


def chunks(items: list, size: int, generator: torch.Generator) -> Iterable[list]:
    """`items` shuffled by `generator`, in lists of `size`."""
    order = torch.randperm(len(items), generator=generator).tolist()
    for i in range(0, len(order), size):
        yield [items[j] for j in order[i : i + size]]


def read_model_config(model_dir: Path, kind: str) -> dict:
    """A model directory's config.json, checked to be of `kind` (UsageError otherwise)."""
    from tleaf_cli.errors import UsageError

    try:
        config = json.loads((model_dir / "config.json").read_text())
    except (OSError, ValueError) as e:
        raise UsageError(f"{model_dir}: not a tleaf model directory ({e})") from None
    if config.get("kind") != kind:
        raise UsageError(f"{model_dir}: a '{config.get('kind')}' model, expected '{kind}'")
    return config


def device_for(name: str) -> torch.device:
    """cpu or cuda (UsageError when cuda is asked for and absent)."""
    from tleaf_cli.errors import UsageError

    if name == "cuda" and not torch.cuda.is_available():
        raise UsageError("--device cuda: no CUDA device is available here")
    if name not in ("cpu", "cuda"):
        raise UsageError(f"--device must be cpu or cuda, not '{name}'")
    return torch.device(name)
