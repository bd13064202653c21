"""GPS L1 C/A signal pieces (IS-GPS-200): spreading codes, and later the LNAV message."""
