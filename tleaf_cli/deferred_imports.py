"""Defers sympy, which ltlf2dfa imports and tleaf never uses: 0.3 s off every process start.

ltlf2dfa's formula module imports `ltlf2dfa.ltlf2dfa` for its `to_dfa`, and that module imports
sympy at import time: 0.3 s of every process that reads a formula (each CLI call, each parallel
worker), for a function tleaf never calls (it runs MONA itself, see logic/mona.py). Unless
ltlf2dfa.ltlf2dfa is already loaded, a stand-in takes its place that loads the real module on
first use of any of its names, so `to_dfa` and everything else still work, only later.
Imported first by `tleaf_cli/__init__.py`, before any module of the package imports ltlf2dfa.
"""

from __future__ import annotations

import importlib
import sys
import types

_DEFERRED = "ltlf2dfa.ltlf2dfa"


class _Deferred(types.ModuleType):
    """`ltlf2dfa.ltlf2dfa` until one of its names is used; `to_dfa` is handed out as a function
    that loads the real module when called (ltlf2dfa.ltlf takes it at import time)."""

    def __getattr__(self, name: str):
        if name.startswith("__"):  # the import system asks for __path__ and the like
            raise AttributeError(name)
        if name == "to_dfa":
            return _to_dfa
        return getattr(_real(), name)


def _real() -> types.ModuleType:
    if isinstance(sys.modules.get(_DEFERRED), _Deferred):
        del sys.modules[_DEFERRED]
    return importlib.import_module(_DEFERRED)


def _to_dfa(*args, **kwargs):
    return _real().to_dfa(*args, **kwargs)


if _DEFERRED not in sys.modules:
    sys.modules[_DEFERRED] = _Deferred(_DEFERRED)
