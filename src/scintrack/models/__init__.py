"""AR scintillation models: fitting, order selection, spectra and look-up tables."""
