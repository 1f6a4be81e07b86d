"""Loading q from a model folder: a damaged folder is an InputError that names the file at fault
and what it should hold (never pickle's, json's or torch's own error, nor torch's advice to load
with weights_only=False), and `logic_loss` takes q's folder as well as q."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import torch

import tleaf_cli as tl
from tleaf_cli.embed.load import load_edge_model, load_embedder
from tleaf_cli.embed.train_meta import MetaSettings, train_meta
from tleaf_cli.errors import ArgumentTypeError, InputError


@pytest.fixture(scope="module")
def meta(chain, tmp_path_factory) -> Path:
    """A tiny trained q (one epoch), its edge model beside it."""
    out = tmp_path_factory.mktemp("q") / "meta"
    train_meta(
        chain["dfas"],
        chain["traces"],
        chain["edge"],
        out,
        MetaSettings(hidden=8, out_dim=8, epochs=1, monitors=0),
    )
    return out


@pytest.fixture
def copy(meta, chain, tmp_path) -> Path:
    """The meta folder and its edge model copied side by side, the config's absolute edge path
    pointing at the copy, so that a test may damage either."""
    shutil.copytree(chain["edge"], tmp_path / "edge")
    shutil.copytree(meta, tmp_path / "meta")
    config = json.loads((tmp_path / "meta" / "config.json").read_text())
    config["edge_model"] = str(tmp_path / "edge")
    config["edge_model_relative"] = "../edge"
    (tmp_path / "meta" / "config.json").write_text(json.dumps(config))
    return tmp_path / "meta"


def _edit_config(folder: Path, edit) -> None:
    path = folder / "config.json"
    config = json.loads(path.read_text())
    edit(config)
    path.write_text(json.dumps(config))


def _refused(folder: Path, file: Path, *words: str) -> str:
    """load_embedder(folder) raises an InputError naming `file` and `words`: its message."""
    with pytest.raises(InputError) as caught:
        load_embedder(folder)
    message = str(caught.value)
    assert str(file) in message, message
    for word in words:
        assert word in message, message
    assert "weights_only" not in message and "\n" not in message, message
    return message


def test_the_copied_folder_loads(copy, meta) -> None:
    """The fixture itself: an undamaged copy loads as the original."""
    assert torch.equal(
        load_embedder(copy).embed_traces([[{"a"}, {"b"}]], [("a", "b")]),
        load_embedder(meta).embed_traces([[{"a"}, {"b"}]], [("a", "b")]),
    )


@pytest.mark.parametrize("folder", ["meta", "edge"])
def test_missing_weights(copy, folder) -> None:
    (copy.parent / folder / "weights.pt").unlink()
    _refused(copy, copy.parent / folder / "weights.pt", "missing")


@pytest.mark.parametrize("folder", ["meta", "edge"])
@pytest.mark.parametrize(
    "damage",
    [
        lambda data: b"not a torch file at all" * 10,  # garbage
        lambda data: data[: len(data) // 2],  # truncated
        lambda data: b"",  # empty
    ],
    ids=["garbage", "truncated", "empty"],
)
def test_unreadable_weights(copy, folder, damage) -> None:
    path = copy.parent / folder / "weights.pt"
    path.write_bytes(damage(path.read_bytes()))
    _refused(copy, path, "not a weights file")


def test_weights_that_run_code_are_refused_without_the_advice_to_run_it(copy) -> None:
    """A pickle torch refuses under weights_only=True: its message advises weights_only=False."""
    path = copy / "weights.pt"
    torch.save({"w": torch.zeros(1), "f": Path("x")}, path)
    _refused(copy, path, "not a weights file")


def test_weights_of_another_model(copy) -> None:
    path = copy / "weights.pt"
    state = torch.load(path, weights_only=True)
    name = next(k for k, t in state.items() if t.dim() == 2)
    state[name] = torch.zeros(state[name].shape[0] + 1, state[name].shape[1])
    torch.save(state, path)
    _refused(copy, path, "another model", name)
    del state[name]
    torch.save(state, path)
    _refused(copy, path, "another model", name)


def test_weights_that_are_not_a_state_dict(copy) -> None:
    torch.save(torch.zeros(3), copy / "weights.pt")
    _refused(copy, copy / "weights.pt", "state dict")


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("[]", ("JSON object", "a list")),
        ('{"kind": "meta-embedder", "settings": {"hid', ("not valid JSON",)),
        ("", ("not valid JSON",)),
        ("\udcff", ("cannot be read",)),
    ],
    ids=["list", "truncated", "empty", "not-utf8"],
)
def test_unreadable_config(copy, text, words) -> None:
    path = copy / "config.json"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    _refused(copy, path, *words)


def test_missing_config(copy) -> None:
    (copy / "config.json").unlink()
    with pytest.raises(InputError, match=r"no config\.json"):
        load_embedder(copy)


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (lambda c: c["settings"].update(hidden="many"), ("'hidden'", "an integer", "'many'")),
        (lambda c: c["settings"].update(hidden=0), ("hidden", "at least 1")),
        (lambda c: c["settings"].update(sphere="yes"), ("'sphere'", "true or false")),
        (lambda c: c["settings"].update(readout="sideways"), ("readout", "sideways")),
        (lambda c: c["settings"].update(colour="blue"), ("settings", "colour")),
        (lambda c: c.update(settings=[1, 2]), ("'settings'", "object")),
        (lambda c: c.pop("settings"), ("'settings'",)),
        (lambda c: c.update(recommended_lambda="big"), ("'recommended_lambda'", "number")),
        (lambda c: c.update(edge_model=7), ("'edge_model'",)),
        (lambda c: c["settings"].update(monitors=3, embedder="syntax"), ("monitors",)),
    ],
    ids=[
        "str-for-int",
        "below-min",
        "str-for-bool",
        "not-a-choice",
        "unknown-setting",
        "settings-list",
        "no-settings",
        "lambda-str",
        "edge-path-int",
        "settings-that-build-no-q",
    ],
)
def test_wrong_config_fields(copy, edit, words) -> None:
    _edit_config(copy, edit)
    _refused(copy, copy / "config.json", *words)


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (lambda c: c.update(vocabulary="abc"), ("'vocabulary'", "a list")),
        (lambda c: c.update(vocabulary=[1, 2]), ("'vocabulary'", "str")),
        (lambda c: c.update(atom_feature_dim="wide"), ("'atom_feature_dim'",)),
        (lambda c: c["settings"].update(layers="two"), ("'layers'", "an integer")),
        (lambda c: c.update(kind="meta-embedder"), ("expected 'edge-embedder'",)),
    ],
    ids=["vocabulary-str", "vocabulary-ints", "feature-dim-str", "layers-str", "kind"],
)
def test_wrong_edge_config_fields(copy, edit, words) -> None:
    edge = copy.parent / "edge"
    _edit_config(edge, edit)
    with pytest.raises(InputError) as caught:
        load_embedder(copy)
    assert str(edge) in str(caught.value)
    for word in words:
        assert word in str(caught.value)


def test_missing_edge_model(copy) -> None:
    shutil.rmtree(copy.parent / "edge")
    message = _refused(copy, copy / "config.json", "edge model")
    assert str(copy.parent / "edge") in message


def test_load_edge_model_names_the_damaged_file(copy) -> None:
    edge = copy.parent / "edge"
    (edge / "weights.pt").write_bytes(b"\x80\x02garbage")
    with pytest.raises(InputError, match=r"weights\.pt"):
        load_edge_model(edge)


def _loss_inputs():
    rules = tl.RuleSet(["G(a -> F(b))", "F(c)"], ["a", "b", "c"])
    log_probs = torch.log_softmax(
        torch.randn(3, 5, 3, generator=torch.Generator().manual_seed(0)), -1
    )
    return log_probs, rules


@pytest.mark.parametrize("as_path", [str, Path])
def test_logic_loss_takes_q_as_its_folder(meta, as_path) -> None:
    log_probs, rules = _loss_inputs()
    by_q = tl.logic_loss("tleaf", log_probs, rules, embedder=load_embedder(meta), reduction="none")
    by_path = tl.logic_loss("tleaf", log_probs, rules, embedder=as_path(meta), reduction="none")
    assert by_path.shape == (3,) and torch.equal(by_path, by_q)


def test_logic_loss_refuses_a_folder_without_q(tmp_path) -> None:
    log_probs, rules = _loss_inputs()
    with pytest.raises(InputError, match="not a tleaf model directory"):
        tl.logic_loss("tleaf", log_probs, rules, embedder=tmp_path / "nothing")


def test_logic_loss_refuses_an_embedder_of_another_type() -> None:
    log_probs, rules = _loss_inputs()
    with pytest.raises(ArgumentTypeError, match=r"embedder.*Embedder.*path.*int"):
        tl.logic_loss("tleaf", log_probs, rules, embedder=42)
