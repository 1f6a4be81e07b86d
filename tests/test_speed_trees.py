"""benchmarks/speed.py times each tree's own code: its commands run `python -P` with the tree
first on PYTHONPATH, and a tree whose commands would import another package is refused."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def speed():
    spec = importlib.util.spec_from_file_location("speed", ROOT / "benchmarks" / "speed.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_each_tree_runs_its_own_package(tmp_path: Path) -> None:
    bench = speed()
    assert bench.command("train-edge")[:2] == [sys.executable, "-P"]
    bench.check_tree(ROOT)  # this checkout: its own package
    other = tmp_path / "baseline"
    (other / "tleaf_cli").mkdir(parents=True)
    (other / "tleaf_cli" / "__init__.py").write_text("")
    assert bench.package_of(other) == (other / "tleaf_cli" / "__init__.py").resolve()
    bench.check_tree(other)
    empty = tmp_path / "empty"  # no package of its own: the installed one would be timed
    empty.mkdir()
    with pytest.raises(SystemExit, match="import tleaf_cli"):
        bench.check_tree(empty)
