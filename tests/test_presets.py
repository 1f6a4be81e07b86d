"""One source of truth for q's settings: presets, automatic choices, saved versions, λ."""

from __future__ import annotations

import json
import shutil
from dataclasses import asdict
from pathlib import Path

import pytest
import torch

from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.meta import (
    AUTO_MONITORS,
    SETTINGS_VERSION,
    MetaSettings,
    recommended_lambda,
    settings_from_config,
)

ROOT = Path(__file__).parent.parent


def test_the_defaults_are_the_best_preset_and_paper_is_the_papers_q() -> None:
    assert (
        MetaSettings()
        == MetaSettings.preset("best")
        == MetaSettings.preset(MetaSettings.default_preset())
    )
    paper = MetaSettings.preset("paper")
    assert (paper.readout, paper.directed, paper.monitors, paper.evidence) == (
        "walk",
        False,
        0,
        False,
    )
    assert (paper.radius_weight, paper.schedule, paper.epochs, paper.patience) == (
        0.0,
        "constant",
        30,
        5,
    )
    assert MetaSettings.preset("paper", epochs=2).epochs == 2  # options override a preset
    with pytest.raises(SettingError, match="preset"):
        MetaSettings.preset("fastest")


@pytest.mark.parametrize(
    ("embedder", "atoms", "monitors", "evidence"),
    [
        ("dfa", 3, 3, True),
        ("dfa", 6, 6, True),
        ("dfa", 15, AUTO_MONITORS, True),
        ("syntax", 3, 0, False),
    ],
)
def test_automatic_choices_follow_the_formulas(embedder, atoms, monitors, evidence) -> None:
    """The Table I pipeline's monitor slots per tier (3 / 3 / 6) and the action-recognition
    pipeline's 10 are what `monitors=None` chooses for their formulas."""
    resolved = MetaSettings(embedder=embedder).resolved(atoms)
    assert (resolved.monitors, resolved.evidence, resolved.sphere) == (monitors, evidence, evidence)
    assert MetaSettings(sphere=False).resolved(3).sphere is False  # a given value stays


def test_settings_that_do_not_fit_together_are_refused() -> None:
    with pytest.raises(SettingError, match="monitors"):
        MetaSettings(embedder="syntax", monitors=3).resolved(3)
    with pytest.raises(SettingError, match="evidence"):
        MetaSettings(readout="walk", evidence=True).resolved(3)
    with pytest.raises(SettingError, match="readout"):
        MetaSettings(readout="diagonal").resolved(3)


def _version_1(settings: MetaSettings) -> dict:
    """A config.json as tleaf wrote it before settings carried a version: every field then,
    the removed ones at the values that changed nothing."""
    old = asdict(settings)
    old.update(length_ranges=1, anchors=0, probe_states=4, probe_mix=0, conv="gcn")
    old.update(head="linear", jumping=False, residual=False, norm=False, pair_weight=0.0)
    return {"kind": "meta-embedder", "settings": old}


def test_a_version_1_config_migrates_on_read() -> None:
    saved = MetaSettings.preset("paper").resolved(3)
    assert settings_from_config(_version_1(saved), "c.json") == saved
    # a field the config predates takes the default of its time, not today's
    old = _version_1(saved)
    del old["settings"]["evidence_scale"], old["settings"]["schedule"]
    migrated = settings_from_config(old, "c.json")
    assert (migrated.evidence_scale, migrated.schedule) == (32.0, "constant")


def test_a_config_using_a_removed_option_or_a_newer_version_is_refused() -> None:
    old = _version_1(MetaSettings.preset("paper").resolved(3))
    old["settings"]["conv"] = "graph"
    with pytest.raises(InputError, match="conv"):
        settings_from_config(old, "c.json")
    newer = {"settings_version": SETTINGS_VERSION + 1, "settings": {}}
    with pytest.raises(InputError, match="newer"):
        settings_from_config(newer, "c.json")


def test_recommended_lambda_puts_qs_boundary_at_one() -> None:
    assert recommended_lambda({"satisfying_distance": 480.0, "violating_distance": 520.0}) == (
        pytest.approx(1 / 500)
    )


@pytest.fixture(scope="module")
def best_q(chain, chain_cli, tmp_path_factory) -> Path:
    """`tleaf train-meta` with no model option: the best preset, trained small and short."""
    out = tmp_path_factory.mktemp("best") / "q"
    args = ["train-meta", chain["dfas"], chain["traces"], "--edge", chain["edge"], "-o", out]
    result = chain_cli(*args, "--epochs", 2, "--hidden", 16, "--out-dim", 8, "-q")
    assert result.exit_code == 0, result.output
    return out


def test_train_meta_without_options_trains_the_best_q_and_records_its_lambda(best_q) -> None:
    config = json.loads((best_q / "config.json").read_text())
    metrics = json.loads((best_q / "metrics.json").read_text())
    assert config["settings_version"] == SETTINGS_VERSION
    want = MetaSettings(epochs=2, hidden=16, out_dim=8).resolved(3)  # low tier: 3 atoms
    assert config["settings"] == asdict(want)
    assert config["recommended_lambda"] == pytest.approx(recommended_lambda(metrics["val"]))
    # the evidence block's distances lie about 2γ² = 512: λ about 1/512
    assert 1 / 1024 < config["recommended_lambda"] < 1 / 256


def test_preset_paper_from_the_command_line(chain, chain_cli, tmp_path) -> None:
    args = ["train-meta", chain["dfas"], chain["traces"], "--edge", chain["edge"]]
    out = tmp_path / "p"
    result = chain_cli(*args, "-o", out, "--preset", "paper", "--epochs", 1, "--hidden", 8, "-q")
    assert result.exit_code == 0, result.output
    saved = json.loads((out / "config.json").read_text())["settings"]
    assert saved == asdict(MetaSettings.preset("paper", epochs=1, hidden=8).resolved(3))
    result = chain_cli(*args, "-o", tmp_path / "x", "--preset", "paper", "--bins", 3)
    assert result.exit_code == 2 and "--bins: only with --readout accept or runs" in result.output


def test_an_older_model_folder_loads_with_the_same_vectors_and_a_lambda(chain, best_q, tmp_path):
    """A folder written before settings carried a version (and before config.json carried λ)
    loads as it did: the same vectors; its λ from the test distances its metrics record."""
    from tleaf_cli.data.dfa_table import read_dfas
    from tleaf_cli.embed.load import load_embedder

    old = tmp_path / "old"
    shutil.copytree(best_q, old)
    config = json.loads((old / "config.json").read_text())
    config.update(_version_1(MetaSettings(**config["settings"])))
    del config["settings_version"], config["recommended_lambda"]
    config["edge_model_relative"] = str(Path("..") / Path(config["edge_model"]).name)
    (old / "config.json").write_text(json.dumps(config))
    rows = [r for r in read_dfas(chain["dfas"]).rows if r["error"] is None][:5]
    ours, theirs = load_embedder(best_q), load_embedder(old)
    assert torch.equal(ours.embed_formula_rows(rows), theirs.embed_formula_rows(rows))
    test = json.loads((old / "metrics.json").read_text())["test"]
    assert theirs.recommended_lambda == pytest.approx(recommended_lambda(test))


def test_docs_cli_md_holds_the_settings_tables_as_generated() -> None:
    """docs/cli.md's option tables of the training commands are the settings dataclasses'
    (regenerate with `python -m tleaf_cli.cli.docs_tables docs/cli.md`)."""
    from tleaf_cli.cli.docs_tables import render_docs

    text = (ROOT / "docs" / "cli.md").read_text()
    assert render_docs(text) == text
