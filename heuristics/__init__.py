"""heuristics package (see README)."""
