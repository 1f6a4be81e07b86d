"""Result figures: matplotlib without a display, PNGs written atomically like every artifact."""

from __future__ import annotations

import os

from tleaf_cli.data.artifacts import atomic_path


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed), imported on first use."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(fig, path: str | os.PathLike, dpi: int = 120) -> None:
    """Write `fig` to `path` through a temporary file, then close it."""
    tmp = atomic_path(path)
    try:
        fig.savefig(tmp, format="png", dpi=dpi)
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)
        pyplot().close(fig)
