"""The `tleaf` command line, the top floor of tleaf: one thin module per stage family.

`app` (the Typer app) and `main` (the entry point) live in `tleaf_cli.cli.root`; they are loaded
on first use, so that `python -m tleaf_cli.cli.docs_tables docs/cli.md` and the settings' option
builders can be imported without every command module.
"""

from __future__ import annotations

from typing import Any

__all__ = ["app", "main"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from tleaf_cli.cli import root

        return getattr(root, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
