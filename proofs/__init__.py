"""proofs package (see README)."""
