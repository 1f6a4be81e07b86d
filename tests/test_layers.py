"""The package's imports run one way: no circle, and none back up a floor.

Floors, lowest first; a module imports modules of lower floors and of its own room only (rooms
of one floor never import each other):

    0 base     errors, version, deferred_imports, arguments, atom_names, defaults, ui,
               settings/, the package root
    1 logic    logic/
    2 data     data/, knowledge/, rule_set, views
    3 q        embed/: q's model, its loading and its embedding (model, load, embedder, ...)
               |  training  training/: the loop, λ, the run folder, one task's run
    4 jobs     embed/'s trainers and vector files (train_edge, train_meta, triplets,
               edge_data, vectors)  |  losses  losses/, decode, shield
    5 tasks    tasks/
    6 cli      cli/

So the loss path (floor 4, room losses) imports no trainer and no dataset reader.

Every `import` is read with `ast`, at module level and inside functions alike (a function's import
runs the first time it is called: a circle through it is a circle), except those under
`if TYPE_CHECKING:`, which never run.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "tleaf_cli"

# (floor, room) of a module by the longest matching name prefix
PLACES: dict[str, tuple[int, str]] = {
    "tleaf_cli": (0, "base"),
    "tleaf_cli.settings": (0, "base"),
    "tleaf_cli.logic": (1, "logic"),
    "tleaf_cli.data": (2, "data"),
    "tleaf_cli.knowledge": (2, "data"),
    "tleaf_cli.rule_set": (2, "data"),
    "tleaf_cli.views": (2, "data"),
    "tleaf_cli.embed": (3, "q"),
    "tleaf_cli.training": (3, "training"),
    **{
        f"tleaf_cli.embed.{name}": (4, "jobs")
        for name in ("train_edge", "train_meta", "triplets", "edge_data", "vectors")
    },
    "tleaf_cli.losses": (4, "losses"),
    "tleaf_cli.decode": (4, "losses"),
    "tleaf_cli.shield": (4, "losses"),
    "tleaf_cli.tasks": (5, "tasks"),
    "tleaf_cli.cli": (6, "cli"),
}


def modules() -> dict[str, Path]:
    """Every module of the package by its dotted name (a package by its own name)."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def place(module: str) -> tuple[int, str]:
    parts = module.split(".")
    for k in range(len(parts), 0, -1):
        if ".".join(parts[:k]) in PLACES:
            return PLACES[".".join(parts[:k])]
    raise AssertionError(f"{module} has no floor: add it to PLACES and to the docstring")


def _type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def imports(path: Path, known: set[str]) -> set[str]:
    """The package's modules that `path` imports (`from a import b`: a.b where that is a module,
    else a), those under `if TYPE_CHECKING:` left out."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skipped = {id(n) for top in ast.walk(tree) if _type_checking(top) for n in ast.walk(top)}
    out = set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name in known}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for a in node.names:
                full = f"{node.module}.{a.name}"
                if full in known:
                    out.add(full)
                elif node.module in known:
                    out.add(node.module)
    return out


def graph() -> dict[str, set[str]]:
    found = modules()
    known = set(found)
    return {name: imports(path, known) - {name} for name, path in found.items()}


def test_every_module_has_a_floor() -> None:
    for module in modules():
        place(module)


def test_no_import_runs_back_up_a_floor_or_across_rooms() -> None:
    wrong = []
    for module, targets in graph().items():
        floor, room = place(module)
        for target in sorted(targets):
            to_floor, to_room = place(target)
            if to_floor > floor or (to_floor == floor and to_room != room):
                wrong.append(f"{module} ({floor} {room}) imports {target} ({to_floor} {to_room})")
    assert not wrong, "\n".join(wrong)


def test_no_import_circle() -> None:
    edges = graph()
    circles = []
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(module: str) -> None:
        state[module] = 1
        path.append(module)
        for target in sorted(edges[module]):
            if state.get(target) == 1:
                circles.append(" -> ".join([*path[path.index(target) :], target]))
            elif target not in state:
                visit(target)
        path.pop()
        state[module] = 2

    for module in sorted(edges):
        if module not in state:
            visit(module)
    assert not circles, "\n".join(circles)


def test_the_walk_sees_function_level_imports_and_skips_type_checking(tmp_path) -> None:
    """The reader itself: an import inside a function counts, one under TYPE_CHECKING does
    not, and `from package import module` names the module."""
    source = tmp_path / "m.py"
    source.write_text(
        "from typing import TYPE_CHECKING\n"
        "from tleaf_cli import arguments\n"
        "if TYPE_CHECKING:\n    from tleaf_cli.cli import root\n"
        "def f():\n    from tleaf_cli.logic.dfa import DFA\n"
    )
    known = {"tleaf_cli", "tleaf_cli.arguments", "tleaf_cli.cli.root", "tleaf_cli.logic.dfa"}
    assert imports(source, known) == {"tleaf_cli.arguments", "tleaf_cli.logic.dfa"}


def _loaded_after(code: str) -> set[str]:
    """The modules a fresh interpreter holds after running `code`."""
    script = code + "\nimport sys\nprint('\\n'.join(sorted(sys.modules)))\n"
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=300, check=True
    )
    return set(result.stdout.split())


def test_the_loss_path_imports_no_trainer_and_no_dataset_reader() -> None:
    loaded = _loaded_after("import tleaf_cli.losses")
    assert "tleaf_cli.losses.logic_loss" in loaded  # the test reads what it means to
    for module in (
        "tleaf_cli.embed.train_meta",
        "tleaf_cli.embed.train_edge",
        "tleaf_cli.data.traces",
    ):
        assert module not in loaded


@pytest.mark.parametrize("kind", ["exact", "checker"])
def test_a_loss_without_q_loads_no_torch_geometric(kind) -> None:
    """torch_geometric (about half of the first call's time) loads only where q runs."""
    loaded = _loaded_after(
        "import torch\nimport tleaf_cli as tl\n"
        "rules = tl.RuleSet(['G(a -> F(b))'], ['a', 'b', 'c'])\n"
        "log_probs = torch.log_softmax(torch.randn(2, 4, 3), -1)\n"
        f"assert tl.logic_loss({kind!r}, log_probs, rules).isfinite()\n"
    )
    assert "tleaf_cli.losses.exact" in loaded
    assert not {m for m in loaded if m.split(".")[0] == "torch_geometric"}
    assert not {m for m in loaded if m.startswith("tleaf_cli.embed")}
