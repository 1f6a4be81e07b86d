"""The library's errors: `TleafError` and its kinds. The library never names a command-line flag.

Every error tleaf raises on purpose is a `TleafError`, so a researcher catches one class. The
kinds say what went wrong, not how the CLI reports it:

* `InputError`    an input is unusable: an unreadable or foreign file, a row or line that is not
                  what was expected, rules whose atoms are not in the vocabulary;
* `SettingError`  a setting's value is out of range; `setting` is its name as the library spells
                  it (a field of a settings object or a keyword argument, e.g. ``logic_loss``);
* `ArgumentError` a public function's argument cannot be used (`ArgumentTypeError`: of the wrong
                  type); `argument` is its name in the signature (tleaf_cli/arguments.py);
* `RulesError`    rules that cannot do what was asked (no sequence of the given length meets them);
* `TleafError` itself: the machine cannot do it (MONA or Graphviz missing or failing).

Only the command line (`tleaf_cli/cli/`) turns them into exit codes and messages; it renders a
`SettingError`'s setting as the flag that sets it (``logic_loss`` → ``--logic-loss``).
"""

from __future__ import annotations


class TleafError(Exception):
    """Every error the library raises on purpose (the CLI: one stderr line, exit status 2)."""

    exit_code = 2


class InputError(TleafError, ValueError):
    """An input (file, row, line, argument value) is not what was expected (a ValueError too)."""


class MissingSplitError(InputError):
    """A traces file without the split column that training and evaluation read (traces drawn
    without a split): the command line adds how to draw them with one."""

    def __init__(self, path: object) -> None:
        super().__init__(f"{path}: no split column (traces drawn without a split)")
        self.path = path


class SettingError(TleafError):
    """A setting's value is out of range: `setting` names it as the library spells it."""

    def __init__(self, setting: str, message: str) -> None:
        super().__init__(message)
        self.setting = setting

    def __str__(self) -> str:
        return f"{self.setting}: {self.args[0]}"


class ArgumentError(TleafError, ValueError):
    """A public function's argument cannot be used (a shape, a range, a NaN, a repeated item):
    `argument` names it as the function's signature does (a ValueError too, as in PyTorch)."""

    def __init__(self, argument: str, message: str) -> None:
        super().__init__(message)
        self.argument = argument

    def __str__(self) -> str:
        return f"{self.argument}: {self.args[0]}"


class ArgumentTypeError(ArgumentError, TypeError):
    """A public function's argument is of the wrong type (a TypeError too, as in PyTorch)."""


class RulesError(TleafError):
    """Rules that cannot do what was asked of them (no sequence of the length given meets them)."""
