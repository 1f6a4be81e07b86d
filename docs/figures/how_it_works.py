"""Draw docs/how-it-works.png: how tleaf turns LTLf rules into a loss (boxes and arrows).

    .venv/bin/python docs/figures/how_it_works.py        # writes docs/how-it-works.png
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "how-it-works.png"

LEARNED = "#dbe9f6"  # T-LEAF's learned path
EXACT = "#e3f1dc"  # exact semantics on the automaton
NEUTRAL = "#f2f2f2"
LOSS = "#fbe3c8"


def box(ax, x0, y0, w, h, text, color=NEUTRAL, size=9, weight="normal", edge="#555555"):
    ax.add_patch(
        FancyBboxPatch(
            (x0, y0), w, h, boxstyle="round,pad=0.02,rounding_size=0.15",
            facecolor=color, edgecolor=edge, linewidth=1.0,
        )
    )
    ax.text(x0 + w / 2, y0 + h / 2, text, ha="center", va="center", fontsize=size,
            weight=weight, linespacing=1.35)


def arrow(ax, start, end, text=None, offset=(0, 0.18), style="-|>", dashed=False, size=8.5):
    ax.add_patch(
        FancyArrowPatch(
            start, end, arrowstyle=style, mutation_scale=12, linewidth=1.1, color="#333333",
            linestyle=(0, (4, 3)) if dashed else "-", shrinkA=0, shrinkB=0,
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
    ax.text(9.5, 10.6, "How tleaf turns temporal rules into a training signal", ha="center",
            fontsize=13, weight="bold")

    # ---- top row: rules -> automaton -> graphs
    box(ax, 0.2, 8.3, 3.0, 1.5, "LTLf rules φ\n(.ltl file, or the rules\na knowledge base gives\na sequence)")
    box(ax, 4.2, 8.3, 3.6, 1.5, "minimal DFA  A_φ\nformula progression or MONA\none-hot alphabet: one item\nper step (or none of φ's)")
    box(ax, 8.8, 8.3, 3.6, 1.5, "automaton graph\na node per state, a node per\nedge carrying its guard\n(a propositional graph)")
    arrow(ax, (3.2, 9.05), (4.2, 9.05), "compile")
    arrow(ax, (7.8, 9.05), (8.8, 9.05), "expand")

    # ---- the embedder q = (q_e, q_m)
    ax.add_patch(FancyBboxPatch((13.2, 4.75), 3.7, 5.2, boxstyle="round,pad=0.02,rounding_size=0.2",
                                facecolor="white", edgecolor="#1f4e79", linewidth=1.4))
    ax.text(15.05, 9.62, "embedder  q = (q_e, q_m)", ha="center", fontsize=9.5, weight="bold",
            color="#1f4e79")
    box(ax, 13.4, 7.75, 3.3, 1.6, "q_e  edge embedder\nGCN over guard graphs;\ntriplet loss on (guard,\nsatisfying, violating letter)", LEARNED, size=8.5)
    box(ax, 13.4, 4.95, 3.3, 2.5, "q_m  meta embedder\nGCN over the graph, q_e's\nvectors on edge nodes;\nreadout of accepted and\nrejected runs; temporal\nmonitors' exact naive-\nBayes evidence block", LEARNED, size=8.5)
    arrow(ax, (15.05, 7.75), (15.05, 7.45))
    arrow(ax, (12.4, 9.05), (13.2, 9.05))

    # ---- bottom row: the model's outputs as a soft trace
    box(ax, 0.2, 5.2, 3.0, 1.6, "sequence model h\nper-step probabilities\nP_t over its vocabulary\n[B, T, V]")
    box(ax, 5.0, 5.2, 6.6, 1.6, "soft trace  w̃\na chain s₀ → e₁ → s₁ → … → e_T → s_T whose edge node t\ncarries Σ_l P_t(l) · q_e(l): the expected letter vector\n(exactly a trace's own when P_t is one-hot)")
    arrow(ax, (3.2, 6.0), (5.0, 6.0), "outputs")
    arrow(ax, (11.6, 6.0), (13.2, 6.0))

    # ---- the T-LEAF loss
    box(ax, 17.45, 5.6, 1.45, 3.2, "T-LEAF\nloss\n\n‖q(A_φ)\n − q(w̃)‖²", LOSS, size=9.5,
        weight="bold")
    arrow(ax, (16.9, 8.6), (17.45, 8.1))
    arrow(ax, (16.9, 5.5), (17.45, 6.1))
    ax.text(17.0, 8.9, "q(A_φ)", ha="center", fontsize=8, style="italic")
    ax.text(17.2, 5.1, "q(w̃)", ha="center", fontsize=8, style="italic")
    # gradient back to h, through P_t only (q is frozen)
    ax.plot([18.15, 18.15, 1.7], [5.6, 4.35, 4.35], color="#a0522d", linestyle=(0, (4, 3)),
            linewidth=1.1)
    arrow(ax, (1.7, 4.35), (1.7, 5.2), dashed=True)
    ax.text(9.6, 4.45, "gradient reaches h through P_t; q stays frozen", ha="center",
            fontsize=8.5, style="italic", color="#a0522d")

    # ---- exact semantics on the automaton
    ax.add_patch(FancyBboxPatch((0.2, 0.25), 18.6, 3.35, boxstyle="round,pad=0.02,rounding_size=0.2",
                                facecolor="#f7fbf4", edgecolor="#4f7f3a", linewidth=1.2))
    ax.text(9.5, 3.25, "where the automaton is used exactly (no embedding): A_φ with the model's P_t", ha="center",
            fontsize=10, weight="bold", color="#3b6a2a")
    specs = [
        ("exact loss\n−log P(A_φ accepts w),\nw drawn from P_t:\nforward algorithm over\nthe DFA (log space)", "training"),
        ("checker\n1 where the argmax\nsequence breaks φ;\nno gradient", "training (reported)"),
        ("constrained decoding\nthe most probable\nsequence A_φ accepts:\nViterbi over\nsteps × DFA states", "inference"),
        ("shield\nbefore each step, the\nactions after which A_φ\ncan still accept\n(masks for a policy)", "acting"),
    ]
    w, gap, x = 4.2, 0.4, 0.55
    for text, use in specs:
        box(ax, x, 0.45, w, 2.35, text, EXACT, size=8.8)
        ax.text(x + w - 0.1, 0.52, use, ha="right", va="bottom", fontsize=7.5, color="#3b6a2a",
                style="italic")
        x += w + gap
    # the DFA feeds every exact use
    ax.plot([4.6, 4.6], [8.3, 4.0], color="#4f7f3a", linewidth=1.1)
    arrow(ax, (4.6, 4.0), (4.6, 3.6))
    ax.text(4.7, 7.6, "A_φ", fontsize=8.5, style="italic", color="#3b6a2a")

    fig.savefig(OUT, dpi=110, bbox_inches="tight")
    print(OUT)


if __name__ == "__main__":
    main()
