"""Library errors know their place: the library names settings its own way, never a CLI flag;
only the CLI turns a SettingError into the flag that sets it (one stderr line, exit status 2)."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest
import typer

from tleaf_cli.cli import app
from tleaf_cli.cli.options import FLAGS, flag
from tleaf_cli.data.traces import TraceSettings
from tleaf_cli.errors import SettingError

PACKAGE = Path(__file__).parent.parent / "tleaf_cli"
FLAG = re.compile(r"--[a-z]")


def _library_modules() -> list[Path]:
    """Every module of the package but the command line's (the cli/ package), the one place
    that knows the flags."""
    cli = PACKAGE / "cli"
    return [p for p in sorted(PACKAGE.rglob("*.py")) if cli not in p.parents]


def _raised_strings(tree: ast.Module) -> list[tuple[int, str]]:
    """(line, text) of every string in a `raise` statement: literals, f-string parts, and
    module-level string constants the statement names (e.g. a hint kept in a constant)."""
    constants = {
        target.id: node.value.value
        for node in tree.body
        if isinstance(node, ast.Assign)
        and isinstance(node.value, ast.Constant)
        and isinstance(node.value.value, str)
        for target in node.targets
        if isinstance(target, ast.Name)
    }
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Raise):
            continue
        for sub in ast.walk(node):
            if isinstance(sub, ast.Constant) and isinstance(sub.value, str):
                found.append((node.lineno, sub.value))
            elif isinstance(sub, ast.Name) and sub.id in constants:
                found.append((node.lineno, constants[sub.id]))
    return found


def test_no_library_error_names_a_cli_flag() -> None:
    offenders = [
        f"{path.relative_to(PACKAGE.parent)}:{line}: {text!r}"
        for path in _library_modules()
        for line, text in _raised_strings(ast.parse(path.read_text(encoding="utf-8")))
        if FLAG.search(text)
    ]
    assert not offenders, "library errors naming a CLI flag:\n" + "\n".join(offenders)


def _cli_options() -> set[str]:
    """Every option name of every `tleaf` command and subcommand (typer's own click inside)."""
    names: set[str] = set()
    stack = [typer.main.get_command(app)]
    while stack:
        command = stack.pop()
        stack.extend(getattr(command, "commands", {}).values())
        for param in command.params:
            if param.param_type_name == "option":
                names.update(param.opts + param.secondary_opts)
    return names


# SettingErrors raised outside a settings class (by stage functions or the cli package), by setting.
CHECKED_BY_STAGES = (
    "tier",
    "split",
    "formula_from",
    "rule_sets",
    "atom_features",
    "dfas",
    "pair_features",
    "min_steps",
)


def test_every_setting_a_command_passes_renders_as_a_real_flag() -> None:
    """A SettingError of a settings class (what the commands fill from their flags) must render
    as a flag some command really has; library-only keywords (a loss's `reduction`) need none."""
    options = _cli_options()
    assert set(FLAGS.values()) <= options and flag("lam") == "--lambda"
    unknown = [name for name in CHECKED_BY_STAGES if flag(name) not in options]
    for path in _library_modules():
        for cls in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(cls, ast.ClassDef) and cls.name.endswith("Settings")):
                continue
            for node in ast.walk(cls):
                if (
                    isinstance(node, ast.Call)
                    and isinstance(node.func, ast.Name)
                    and node.func.id == "SettingError"
                    and node.args
                    and isinstance(node.args[0], ast.Constant)
                    and flag(node.args[0].value) not in options
                ):
                    unknown.append(f"{path.name}:{node.lineno}: {node.args[0].value}")
    assert not unknown, "settings with no flag of that name:\n" + "\n".join(unknown)


def test_the_library_names_the_setting_its_own_way() -> None:
    with pytest.raises(SettingError) as e:
        TraceSettings(hard_fraction=2.0).check()
    assert e.value.setting == "hard_fraction"
    assert str(e.value) == "hard_fraction: must be in [0, 1], got 2.0"


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["gen-traces", "{missing}", "--hard-fraction", "2"], "--hard-fraction: must be in [0, 1]"),
        (["gen-formulas", "--atoms", "3", "--size", "4"], "--size: 4 cannot hold 3 distinct atoms"),
        (["gen-formulas", "--prefix", "a b#"], "--prefix: starts formula names: only ASCII"),
    ],
)
def test_a_setting_error_reaches_the_cli_as_its_flag(
    tmp_path: Path, args: list[str], expected: str
) -> None:
    tleaf = Path(sys.executable).parent / "tleaf"
    command = [a.format(missing=tmp_path / "none.parquet") for a in args]
    result = subprocess.run(
        [str(tleaf), *command, "-o", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ") and expected in lines[0]
    assert "_" not in lines[0].split(":")[1]  # the flag, not the library's name
    assert not (tmp_path / "out").exists()
