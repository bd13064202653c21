"""On-line estimators on prompt-correlator outputs (C/N0, noise power, S4)."""
