"""GPS L1 C/A spreading codes, PRN 1-32 (IS-GPS-200 Rev D, Sec. 3.3.2.3, Table 3-Ia).

Two 10-stage shift registers, both started all ones, clocked at 1.023 Mcps:

* G1 = 1 + x^3 + x^10 (feedback from stages 3 and 10), output stage 10;
* G2 = 1 + x^2 + x^3 + x^6 + x^8 + x^9 + x^10, whose output for a given PRN
  is the modulo-2 sum of two of its stages (the "phase selector" taps of
  Table 3-Ia), equivalent to G2 delayed by the PRN's code phase.

The C/A chip is G1 xor G2i; a period is 1023 chips (1 ms).  Chips are
returned as 0/1 (:func:`ca_code_bits`) or as the +-1 levels a correlator
uses, with bit 0 -> +1 and bit 1 -> -1 (:func:`ca_code`).  The codes are
computed once per PRN and cached.
"""

from __future__ import annotations

from functools import cache

import numpy as np

CHIPS = 1023
CHIP_RATE_HZ = 1.023e6

#: G2 phase-selector taps (stages, 1-based) of PRN 1-32, IS-GPS-200 Table 3-Ia.
G2_TAPS: dict[int, tuple[int, int]] = {
    1: (2, 6), 2: (3, 7), 3: (4, 8), 4: (5, 9), 5: (1, 9), 6: (2, 10), 7: (1, 8), 8: (2, 9),
    9: (3, 10), 10: (2, 3), 11: (3, 4), 12: (5, 6), 13: (6, 7), 14: (7, 8), 15: (8, 9), 16: (9, 10),
    17: (1, 4), 18: (2, 5), 19: (3, 6), 20: (4, 7), 21: (5, 8), 22: (6, 9), 23: (1, 3), 24: (4, 6),
    25: (5, 7), 26: (6, 8), 27: (7, 9), 28: (8, 10), 29: (1, 6), 30: (2, 7), 31: (3, 8), 32: (4, 9),
}

_G1_FEEDBACK = (3, 10)
_G2_FEEDBACK = (2, 3, 6, 8, 9, 10)


@cache
def _ca_bits(prn: int) -> bytes:
    if prn not in G2_TAPS:
        raise ValueError(f"PRN {prn} has no C/A code in IS-GPS-200 Table 3-Ia (1-32)")
    s1, s2 = G2_TAPS[prn]
    g1 = [1] * 10  # g1[0] is stage 1
    g2 = [1] * 10
    out = bytearray(CHIPS)
    for i in range(CHIPS):
        out[i] = g1[9] ^ g2[s1 - 1] ^ g2[s2 - 1]
        f1 = 0
        for stage in _G1_FEEDBACK:
            f1 ^= g1[stage - 1]
        f2 = 0
        for stage in _G2_FEEDBACK:
            f2 ^= g2[stage - 1]
        g1 = [f1] + g1[:9]
        g2 = [f2] + g2[:9]
    return bytes(out)


def ca_code_bits(prn: int) -> np.ndarray:
    """One period of the C/A code of ``prn`` as 0/1 chips (uint8, 1023)."""
    return np.frombuffer(_ca_bits(int(prn)), dtype=np.uint8).copy()


def ca_code(prn: int) -> np.ndarray:
    """One period of the C/A code of ``prn`` as +-1 levels (bit 0 -> +1, bit 1 -> -1), float64."""
    return 1.0 - 2.0 * ca_code_bits(prn)
