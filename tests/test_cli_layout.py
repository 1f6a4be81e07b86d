"""The command line is the top floor and its rooms are thin: no CLI module over 300 lines, no
module below it imports it, and inside it imports run one way (root -> command modules ->
common / options / formatting / runs / prediction_tables), so there is no circle."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).parent.parent / "tleaf_cli"
CLI = PACKAGE / "cli"
# Inside the cli package, what each kind of module may import of it.
SHARED = {"options", "formatting", "common", "runs", "prediction_tables"}


def _imports(path: Path) -> set[str]:
    """The tleaf_cli modules `path` imports, anywhere in it (functions included)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{a.name}" for a in node.names)
    return {name for name in found if name.startswith("tleaf_cli")}


def test_no_cli_module_is_over_300_lines() -> None:
    sizes = {p.name: len(p.read_text(encoding="utf-8").splitlines()) for p in CLI.glob("*.py")}
    assert max(sizes.values()) <= 300, sizes


def test_no_module_of_the_package_is_over_500_lines() -> None:
    """A module past 500 lines has grown a second job: split it by what each part does."""
    sizes = {
        str(p.relative_to(PACKAGE)): len(p.read_text(encoding="utf-8").splitlines())
        for p in PACKAGE.rglob("*.py")
    }
    assert {name: n for name, n in sizes.items() if n > 500} == {}


def test_nothing_below_the_cli_imports_it() -> None:
    offenders = [
        str(p.relative_to(PACKAGE.parent))
        for p in PACKAGE.rglob("*.py")
        if CLI not in p.parents
        and any(n == "tleaf_cli.cli" or n.startswith("tleaf_cli.cli.") for n in _imports(p))
    ]
    assert not offenders, offenders


def test_cli_imports_run_one_way() -> None:
    """Command modules import only the shared modules; the shared ones import no command module
    and not root; only root (and the package's lazy __init__) imports the command modules."""
    for path in CLI.glob("*.py"):
        used = {
            n.removeprefix("tleaf_cli.cli.").split(".")[0]
            for n in _imports(path)
            if n.startswith("tleaf_cli.cli.")
        }
        name = path.stem
        if name in ("root", "__init__"):
            continue
        allowed = {"options"} if name in SHARED else SHARED
        if name == "common":
            allowed = {"options"}
        if name == "options":
            allowed = set()
        assert used <= allowed, (name, used - allowed)
