"""Values printed in the papers, transcribed for the paper-vs-reproduced twins.

Source: ``shared/papers/vila-valls-2018-scintillation-mitigation.txt``.
"""

# Table I: AR(q) amplitude and AR(p) phase orders per scintillation region.
VILA_VALLS_2018_TABLE_I = {
    "severe": {"s4_range": "0.6 < S4", "amplitude": 3, "phase": 1},
    "moderate": {"s4_range": "0.3 < S4 <= 0.6", "amplitude": 3, "phase": 2},
    "low": {"s4_range": "S4 <= 0.3", "amplitude": 3, "phase": 3},
}
