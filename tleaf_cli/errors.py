"""Errors that end a stage with a one-line message and an exit status (DESIGN.md: 1 or 2)."""


class UsageError(Exception):
    """The call itself is unusable: bad option, unreadable or foreign input file (exit 2)."""

    exit_code = 2
