"""The package version, in one place: pyproject.toml reads it, artifacts and caches record it."""

__version__ = "0.1.0"
