"""The interface a dataset reader implements: read a source into `Cases`, write them as its
artifact.

A new dataset of sequences (another event-log format, another annotated video dataset) needs one
class with these two methods, and every later stage reads its cases as it reads the others':

- `read(progress)` reads the whole source into `Cases` (data/cases.py): the cases in the
  source's order, each with its activities in time order, their atoms, times and split; what it
  skipped in `Cases.skips` (`SkipReport`, counted by kind with the first places named); the files
  it read in `Cases.inputs`. It raises `InputError` (naming the file, line or row) for a source
  it cannot use as a whole, and writes nothing. `progress(done, total)`, when given, is told how
  far it is (bytes, or items), at the end `done == total`.
- `write(cases, out)` writes them as the reader's artifact, atomically (data/artifacts.py).

Implemented by `log_readers.LogReader` (XES and CSV event logs, the `cases` artifact) and
`captaincook.CaptainCookReader` (CaptainCook4D's annotations, the `recordings` artifact).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Protocol, runtime_checkable

from tleaf_cli.data.cases import Cases

Progress = Callable[[int, int], None]  # (done, total)


@runtime_checkable
class CaseReader(Protocol):
    """A dataset reader (see the module docstring)."""

    def read(self, progress: Progress | None = None) -> Cases:
        """The source's cases, with what was skipped; InputError if it is unusable."""
        ...

    def write(self, cases: Cases, out: str | os.PathLike) -> None:
        """Write `cases` as this reader's artifact at `out`, atomically."""
        ...
