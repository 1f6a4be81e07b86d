"""Defaults shared by the library and the command line, in a module light enough to import
before anything heavy (the CLI reads them to build its options)."""

# Seconds MONA may spend on one formula in compile-dfa.
COMPILE_TIMEOUT = 30.0
# Candidates are cheap to replace, so gen-formulas gives MONA less time per formula.
CANDIDATE_TIMEOUT = 5.0
# Trace lengths used by gen-traces, and assumed by gen-formulas when it judges formulas.
MIN_LEN = 2
MAX_LEN = 12
# The paper's model-checking tiers: (number of atoms, syntax-tree size).
TIERS: dict[str, tuple[int, int]] = {"low": (3, 10), "moderate": (3, 20), "high": (6, 20)}
