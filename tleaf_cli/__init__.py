"""tleaf: temporal knowledge in LTLf, compiled to automata and embedded for deep sequence models."""

__version__ = "0.1.0"
