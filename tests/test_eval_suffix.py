"""eval next-activity's suffix figures as the suffix benchmark reads them: scored on the
validation split when asked (to choose a way there), pooled over every prefix of every length
(each length weighted by its prefixes), with the minimum-Bayes-risk way beside argmax and beam."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.test_next_activity import one_line, tleaf
from tests.test_next_activity import tiny_run as run  # noqa: F401
from tleaf_cli.data.event_logs import read_cases


def test_the_validation_split_pooled_with_mbr(run, tmp_path) -> None:  # noqa: F811
    data, out = run
    result = tleaf(
        "eval", "next-activity", out, data, "--split", "val", "--prefix-lengths", "1-4",
        "--min-suffix", 1, "--mbr-samples", 6, "--max-suffix", 12, "-o", tmp_path / "e",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    metrics = json.loads((tmp_path / "e" / "metrics.json").read_text())
    val = [c for c in read_cases(data).cases if c.split == "val"]
    assert metrics["split"] == "val" and metrics["test_cases"] == len(val)
    rows = [r for r in metrics["suffix"].values() if r.get("cases")]
    # every prefix with at least one activity after it, of the lengths asked
    assert sum(r["cases"] for r in rows) == sum(min(len(c) - 1, 4) for c in val)
    pooled = metrics["suffix_pooled"]
    assert pooled["prefixes"] == sum(r["cases"] for r in rows)
    for way in ("argmax", "beam", "mbr"):
        weights = [r["cases"] for r in rows]
        mean = np.average([r[way]["dl_similarity"] for r in rows], weights=weights)
        assert pooled[way]["dl_similarity"] == pytest.approx(mean)
        assert 0.0 <= pooled[way]["at_cap"] <= 1.0
    assert "prefixes pooled" in result.output and "mbr" in result.output


def test_mbr_samples_without_prefix_lengths_is_refused(run, tmp_path) -> None:  # noqa: F811
    data, out = run
    line = one_line(tleaf("eval", "next-activity", out, data, "--mbr-samples", 4))
    assert "--mbr-samples" in line and "--prefix-lengths" in line, line
    result = tleaf("eval", "next-activity", out, data, "--split", "train")
    assert result.exit_code == 2 and "'--split'" in result.output, result.output
