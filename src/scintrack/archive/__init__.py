"""Publication bundle: deterministic archive, its metadata, verification and the paper comparison page."""
