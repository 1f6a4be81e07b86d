"""Draw docs/how-it-works.png: how tleaf turns LTLf rules into a loss (boxes and arrows).

.venv/bin/python docs/figures/how_it_works.py        # writes docs/how-it-works.png
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch


def L(*lines: str) -> str:
    """A box's text, one argument per line."""
    return "\n".join(lines)


OUT = Path(__file__).resolve().parents[1] / "how-it-works.png"

LEARNED = "#dbe9f6"  # T-LEAF's learned path
EXACT = "#e3f1dc"  # exact semantics on the automaton
NEUTRAL = "#f2f2f2"
LOSS = "#fbe3c8"


def box(ax, x0, y0, w, h, text, color=NEUTRAL, size=9, weight="normal", edge="#555555"):
    ax.add_patch(
        FancyBboxPatch(
            (x0, y0),
            w,
            h,
            boxstyle="round,pad=0.02,rounding_size=0.15",
            facecolor=color,
            edgecolor=edge,
            linewidth=1.0,
        )
    )
    ax.text(
        x0 + w / 2,
        y0 + h / 2,
        text,
        ha="center",
        va="center",
        fontsize=size,
        weight=weight,
        linespacing=1.35,
    )


def arrow(ax, start, end, text=None, offset=(0, 0.18), style="-|>", dashed=False, size=8.5):
    ax.add_patch(
        FancyArrowPatch(
            start,
            end,
            arrowstyle=style,
            mutation_scale=12,
            linewidth=1.1,
            color="#333333",
            linestyle=(0, (4, 3)) if dashed else "-",
            shrinkA=0,
            shrinkB=0,
        )
    )
    if text:
        mx, my = (start[0] + end[0]) / 2 + offset[0], (start[1] + end[1]) / 2 + offset[1]
        ax.text(mx, my, text, ha="center", va="bottom", fontsize=size, style="italic")


def main() -> None:
    fig, ax = plt.subplots(figsize=(14, 8.2))
    ax.set_xlim(0, 19)
    ax.set_ylim(0, 11)
    ax.axis("off")
    ax.text(
        9.5,
        10.6,
        "How tleaf turns temporal rules into a training signal",
        ha="center",
        fontsize=13,
        weight="bold",
    )

    # ---- top row: rules -> automaton -> graphs
    box(
        ax,
        0.2,
        8.3,
        3.0,
        1.5,
        L("LTLf rules φ", "(.ltl file, or the rules", "a knowledge base gives", "a sequence)"),
    )
    box(
        ax,
        4.2,
        8.3,
        3.6,
        1.5,
        L(
            "minimal DFA  A_φ",
            "formula progression or MONA",
            "one-hot alphabet: one item",
            "per step (or none of φ's)",
        ),
    )
    box(
        ax,
        8.8,
        8.3,
        3.6,
        1.5,
        L(
            "automaton graph",
            "a node per state, a node per",
            "edge carrying its guard",
            "(a propositional graph)",
        ),
    )
    arrow(ax, (3.2, 9.05), (4.2, 9.05), "compile")
    arrow(ax, (7.8, 9.05), (8.8, 9.05), "expand")

    # ---- the embedder q = (q_e, q_m)
    ax.add_patch(
        FancyBboxPatch(
            (13.2, 4.75),
            3.7,
            5.2,
            boxstyle="round,pad=0.02,rounding_size=0.2",
            facecolor="white",
            edgecolor="#1f4e79",
            linewidth=1.4,
        )
    )
    ax.text(
        15.05,
        9.62,
        "embedder  q = (q_e, q_m)",
        ha="center",
        fontsize=9.5,
        weight="bold",
        color="#1f4e79",
    )
    box(
        ax,
        13.4,
        7.75,
        3.3,
        1.6,
        L(
            "q_e  edge embedder",
            "GCN over guard graphs;",
            "triplet loss on (guard,",
            "satisfying, violating letter)",
        ),
        LEARNED,
        size=8.5,
    )
    box(
        ax,
        13.4,
        4.95,
        3.3,
        2.5,
        L(
            "q_m  meta embedder",
            "GCN over the graph, q_e's",
            "vectors on edge nodes;",
            "readout of accepted and",
            "rejected runs; temporal",
            "monitors' exact naive-",
            "Bayes evidence block",
        ),
        LEARNED,
        size=8.5,
    )
    arrow(ax, (15.05, 7.75), (15.05, 7.45))
    arrow(ax, (12.4, 9.05), (13.2, 9.05))

    # ---- bottom row: the model's outputs as a soft trace
    box(
        ax,
        0.2,
        5.2,
        3.0,
        1.6,
        L("sequence model h", "per-step probabilities", "P_t over its vocabulary", "[B, T, V]"),
    )
    box(
        ax,
        5.0,
        5.2,
        6.6,
        1.6,
        L(
            "soft trace  w̃",
            "a chain s₀ → e₁ → s₁ → … → e_T → s_T whose edge node t",
            "carries Σ_l P_t(l) · q_e(l): the expected letter vector",
            "(exactly a trace's own when P_t is one-hot)",
        ),
    )
    arrow(ax, (3.2, 6.0), (5.0, 6.0), "outputs")
    arrow(ax, (11.6, 6.0), (13.2, 6.0))

    # ---- the T-LEAF loss
    box(
        ax,
        17.45,
        5.6,
        1.45,
        3.2,
        L("T-LEAF", "loss", "", "‖q(A_φ)", " − q(w̃)‖²"),
        LOSS,
        size=9.5,
        weight="bold",
    )
    arrow(ax, (16.9, 8.6), (17.45, 8.1))
    arrow(ax, (16.9, 5.5), (17.45, 6.1))
    ax.text(17.0, 8.9, "q(A_φ)", ha="center", fontsize=8, style="italic")
    ax.text(17.2, 5.1, "q(w̃)", ha="center", fontsize=8, style="italic")
    # gradient back to h, through P_t only (q is frozen)
    ax.plot(
        [18.15, 18.15, 1.7],
        [5.6, 4.35, 4.35],
        color="#a0522d",
        linestyle=(0, (4, 3)),
        linewidth=1.1,
    )
    arrow(ax, (1.7, 4.35), (1.7, 5.2), dashed=True)
    ax.text(
        9.6,
        4.45,
        "gradient reaches h through P_t; q stays frozen",
        ha="center",
        fontsize=8.5,
        style="italic",
        color="#a0522d",
    )

    # ---- exact semantics on the automaton
    ax.add_patch(
        FancyBboxPatch(
            (0.2, 0.25),
            18.6,
            3.35,
            boxstyle="round,pad=0.02,rounding_size=0.2",
            facecolor="#f7fbf4",
            edgecolor="#4f7f3a",
            linewidth=1.2,
        )
    )
    ax.text(
        9.5,
        3.25,
        "where the automaton is used exactly (no embedding): A_φ with the model's P_t",
        ha="center",
        fontsize=10,
        weight="bold",
        color="#3b6a2a",
    )
    specs = [
        (
            L(
                "exact loss",
                "−log P(A_φ accepts w),",
                "w drawn from P_t:",
                "forward algorithm over",
                "the DFA (log space)",
            ),
            "training",
        ),
        (
            L("checker", "1 where the argmax", "sequence breaks φ;", "no gradient"),
            "training (reported)",
        ),
        (
            L(
                "constrained decoding",
                "the most probable",
                "sequence A_φ accepts:",
                "Viterbi over",
                "steps × DFA states",
            ),
            "inference",
        ),
        (
            L(
                "shield",
                "before each step, the",
                "actions after which A_φ",
                "can still accept",
                "(masks for a policy)",
            ),
            "acting",
        ),
    ]
    w, gap, x = 4.2, 0.4, 0.55
    for text, use in specs:
        box(ax, x, 0.45, w, 2.35, text, EXACT, size=8.8)
        ax.text(
            x + w - 0.1,
            0.52,
            use,
            ha="right",
            va="bottom",
            fontsize=7.5,
            color="#3b6a2a",
            style="italic",
        )
        x += w + gap
    # the DFA feeds every exact use
    ax.plot([4.6, 4.6], [8.3, 4.0], color="#4f7f3a", linewidth=1.1)
    arrow(ax, (4.6, 4.0), (4.6, 3.6))
    ax.text(4.7, 7.6, "A_φ", fontsize=8.5, style="italic", color="#3b6a2a")

    fig.savefig(OUT, dpi=110, bbox_inches="tight")
    print(OUT)


if __name__ == "__main__":
    main()
