"""GPS C/A codes against IS-GPS-200: first chips, balance, and the Gold-code correlation values."""

from __future__ import annotations

import numpy as np
import pytest

from scintrack.signals.gps.ca_code import CHIPS, G2_TAPS, ca_code, ca_code_bits

FIRST_10_OCTAL = {1: "1440", 11: "1642", 28: "1774", 30: "1453"}  # IS-GPS-200 Table 3-Ia
G2_DELAY = {1: 5, 11: 252, 28: 516, 30: 860}  # the same codes as a delayed G2 (Table 3-Ia)


def _lfsr(feedback, n=CHIPS):
    """Independent register: numpy array state, output of stage 10."""
    state = np.ones(10, dtype=np.uint8)
    out = np.empty(n, dtype=np.uint8)
    for i in range(n):
        out[i] = state[9]
        new = np.bitwise_xor.reduce(state[np.asarray(feedback) - 1])
        state = np.roll(state, 1)
        state[0] = new
    return out


@pytest.mark.parametrize("prn", sorted(FIRST_10_OCTAL))
def test_first_ten_chips_match_the_spec_table(prn):
    bits = ca_code_bits(prn)[:10]
    assert format(int("".join(map(str, bits)), 2), "o") == FIRST_10_OCTAL[prn]


@pytest.mark.parametrize("prn", sorted(G2_DELAY))
def test_tap_coder_equals_g1_xor_delayed_g2(prn):
    g1 = _lfsr((3, 10))
    g2 = _lfsr((2, 3, 6, 8, 9, 10))
    delayed = np.roll(g2, G2_DELAY[prn])  # G2(t - delay)
    np.testing.assert_array_equal(ca_code_bits(prn), g1 ^ delayed)


def _circular_correlation(a, b):
    return np.real(np.fft.ifft(np.fft.fft(a) * np.conj(np.fft.fft(b)))).round().astype(int)


@pytest.mark.parametrize("prn", range(1, 33))
def test_every_code_is_balanced_with_three_valued_autocorrelation(prn):
    code = ca_code(prn)
    assert code.size == CHIPS and int(ca_code_bits(prn).sum()) == 512
    r = _circular_correlation(code, code)
    assert r[0] == CHIPS
    assert set(np.unique(r[1:])) <= {-65, -1, 63}


def test_cross_correlations_take_the_gold_code_values():
    codes = {prn: ca_code(prn) for prn in (1, 11, 28, 30, 5, 17)}
    for a in codes:
        for b in codes:
            if a < b:
                assert set(np.unique(_circular_correlation(codes[a], codes[b]))) <= {-65, -1, 63}, (a, b)


def test_codes_are_distinct_and_unknown_prn_is_an_error():
    assert len({ca_code_bits(p).tobytes() for p in G2_TAPS}) == 32
    with pytest.raises(ValueError, match="PRN 33"):
        ca_code_bits(33)
