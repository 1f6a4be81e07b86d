"""The paper's Fig. 3: one test formula and its satisfying / violating traces, embedded and
projected to 2-D with t-SNE, side by side for each embedder (`tleaf eval tsne`).

The formula is a test-split formula (never trained on). Its traces are drawn afresh from its DFA
with the data stage's sampler — more of them than the traces file holds, so the picture is not
just twenty dots — as pairs of equal length: satisfying, uniform violating and hard violating
(a minimal edit of a satisfying trace). Every point is labelled by the exact DFA, never by a model.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from tleaf_cli.data.artifacts import check_writable
from tleaf_cli.data.dfa_table import dfa_from_row, read_dfas
from tleaf_cli.data.traces import TraceSettings, read_traces, traces_for_dfa
from tleaf_cli.embed.load import load_embedder
from tleaf_cli.errors import InputError, MissingSplitError
from tleaf_cli.settings.evaluation import FigureSettings
from tleaf_cli.tasks.figures import pyplot, save_png

STYLE = {  # kind of point -> (marker, colour, legend)
    "sat": ("o", "tab:green", "satisfying"),
    "uniform": ("x", "tab:red", "violating (uniform)"),
    "hard": ("^", "tab:orange", "violating (hard: one edit)"),
}


def pick_test_formula(traces_path: str | Path, rows: dict[str, dict]) -> str:
    """The test-split formula with the most traces in the file (ties: the smallest id)."""
    table = read_traces(traces_path)
    if "split" not in table.column_names:
        raise MissingSplitError(traces_path)
    counts: dict[str, int] = {}
    for fid, split in zip(
        table.column("formula_id").to_pylist(), table.column("split").to_pylist(), strict=True
    ):
        if split == "test" and fid in rows:
            counts[fid] = counts.get(fid, 0) + 1
    if not counts:
        raise InputError(f"{traces_path}: no compiled test-split formula to draw")
    return min(counts, key=lambda f: (-counts[f], f))


def tsne_figure(
    model_dirs: Sequence[str | Path],
    dfas_path: str | Path,
    traces_path: str | Path,
    out_png: str | Path,
    settings: FigureSettings,
) -> dict:
    """Write the PNG; returns what it shows (formula, point counts, per-embedder separation)."""
    plt = pyplot()
    from sklearn.manifold import TSNE

    check_writable(Path(out_png))
    rows = {r["formula_id"]: r for r in read_dfas(dfas_path).rows if r["error"] is None}
    fid = settings.formula_id or pick_test_formula(traces_path, rows)
    if fid not in rows:
        raise InputError(f"{dfas_path}: no compiled formula with id {fid!r}")
    row = rows[fid]
    dfa = dfa_from_row(row)
    drawn = traces_for_dfa(
        dfa,
        TraceSettings(per_formula=settings.pairs, one_hot=row["alphabet"] == "one-hot"),
        np.random.default_rng(settings.seed),
    )
    if not drawn.words:
        raise InputError(f"formula {fid!r}: {drawn.shortfall}")
    traces = [[set(dfa.alphabet.letter(int(x))) for x in w] for w in drawn.words]
    kinds = np.array(
        ["sat" if ok else src for ok, src in zip(drawn.labels, drawn.sources, strict=True)]
    )
    atoms = tuple(row["atoms"])
    one_hot = row["alphabet"] == "one-hot"

    fig, axes = plt.subplots(1, len(model_dirs), figsize=(5.2 * len(model_dirs), 5), squeeze=False)
    shown = {"formula_id": fid, "formula": row["formula"], "points": {}, "embedders": []}
    for k in STYLE:
        shown["points"][k] = int((kinds == k).sum())
    for ax, model_dir in zip(axes[0], model_dirs, strict=True):
        q = load_embedder(model_dir)
        with torch.no_grad():
            z = torch.cat(
                [
                    q.embed_formula_rows([row]),
                    q.embed_traces(traces, [atoms] * len(traces), [one_hot] * len(traces)),
                ]
            ).numpy()
        xy = TSNE(
            n_components=2,
            perplexity=min(settings.perplexity, (len(z) - 1) / 3),
            init="pca",
            random_state=settings.seed,
        ).fit_transform(z)
        for k, (marker, colour, legend) in STYLE.items():
            pts = xy[1:][kinds == k]
            ax.scatter(pts[:, 0], pts[:, 1], marker=marker, c=colour, s=18, label=legend)
        ax.scatter(*xy[0], marker="*", c="black", s=260, label="the formula (its DFA)")
        ax.set_title(f"{q.kind} embedder ({Path(model_dir).name})")
        ax.set_xticks([])
        ax.set_yticks([])
        shown["embedders"].append(
            {"model": str(model_dir), "kind": q.kind, **_separation(z, kinds)}
        )
    axes[0][0].legend(loc="best", fontsize=8)
    fig.suptitle(
        f"t-SNE of test formula {fid} (never trained on) and traces drawn from its DFA "
        "(synthetic data)\n" + _shorten(row["formula"]),
        fontsize=9,
    )
    fig.tight_layout()
    save_png(fig, out_png, dpi=110)
    return shown


def _separation(z: np.ndarray, kinds: np.ndarray) -> dict:
    """In the embedding space itself (not the 2-D picture): how often a satisfying trace is
    nearer the formula than a violating one, over all such pairs."""
    d = ((z[1:] - z[0]) ** 2).sum(axis=1)
    sat, neg = d[kinds == "sat"], d[kinds != "sat"]
    return {"sat_nearer_than_violating": float((sat[:, None] < neg[None, :]).mean())}


def _shorten(text: str, width: int = 110) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"
