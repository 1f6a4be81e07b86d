"""Settings of the embedder's evaluations: `tleaf eval model-checking` (`EvalSettings`, the
paper's Table I) and `tleaf eval tsne` (`FigureSettings`, its Fig. 3). Pure Python: the command
line builds both commands' options from this module."""

from __future__ import annotations

from dataclasses import dataclass

from tleaf_cli.settings import DEVICES, PRECISIONS, setting

PAIR_FEATURES = ("concat", "rich")  # the MLP's input built from (z_formula, z_trace)


@dataclass(frozen=True)
class EvalSettings:
    """Every setting of a model-checking evaluation (saved in its report.json)."""

    pair_features: str = setting(
        "concat", "concat (the paper's) or rich (adds |a-b| and a*b).", choices=PAIR_FEATURES
    )
    hidden: tuple[int, int] = (512, 128)  # the MLP's hidden layers (the paper's)
    lr: float = 1e-3
    batch_size: int = 256
    epochs: int = 100
    patience: int = 10
    label: str = setting("", "A name for the report (e.g. the tier).")
    all_negatives: bool = setting(
        False, "Also fit a second MLP on all negatives, hard ones too (doubles the time)."
    )
    device: str = setting("cpu", "Where q embeds and the MLPs train: cpu or cuda.", choices=DEVICES)
    precision: str = setting(
        "float32",
        "float32; bfloat16: the MLPs' products under autocast, 3-4x faster on CPUs with AMX / "
        "AVX-512 BF16 (slower on others); auto: bfloat16 where the hardware computes it "
        "natively, else float32.",
        choices=PRECISIONS,
    )
    seed: int = setting(0, "Random seed; the same seed writes the same file.")


@dataclass(frozen=True)
class FigureSettings:
    """Every setting of the t-SNE figure."""

    formula_id: str | None = setting(
        None, "Formula id.", auto="the test formula with the most traces"
    )
    pairs: int = setting(150, "Satisfying/violating pairs to draw.", min=2)
    perplexity: float = 20.0
    seed: int = setting(0, "Random seed; the same seed writes the same file.")
