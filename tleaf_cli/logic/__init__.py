"""LTLf, MONA and DFAs. Pure logic: numpy at most, never torch."""
