"""LNAV subframes 1-3: parity checked independently of the encoder, field round trips, HOW timing."""

from __future__ import annotations

import numpy as np
import pytest

from scintrack.signals.gps.lnav import (
    FIELDS,
    PREAMBLE,
    decode_subframe,
    dequantise,
    encode_subframe,
    how_tow,
    read_fields,
    source_bits,
    subframe_id,
)

# RTKLIB-style check, written from the spec's equations as bit masks over a 32-bit word
# holding D29*, D30* in bits 31-30 and D1..D30 in bits 29-0 (not the encoder's code).
HAMMING = (0xBB1F3480, 0x5D8F9A40, 0xAEC7CD00, 0x5763E680, 0x6BB1F340, 0x8B7A89C0)


def independent_parity_ok(word32: int) -> bool:
    if word32 & 0x40000000:
        word32 ^= 0x3FFFFFC0
    parity = 0
    for mask in HAMMING:
        parity = (parity << 1) | (bin(word32 & mask).count("1") & 1)  # no mask touches D25..D30
    return parity == (word32 & 0x3F)


def _bits_to_int(bits):
    return int("".join(map(str, bits)), 2)


def random_data_set(rng: np.random.Generator) -> dict[str, float]:
    """Every subframe 1-3 field at a random value the message can carry exactly."""
    values = {}
    for sf in (1, 2, 3):
        for name, field in FIELDS[sf].items():
            raw = int(rng.integers(0, 1 << field.bits))
            values[name] = raw if field.scale == 0 and not field.signed else dequantise(raw, field)
    values["iode"] = values["iodc"] % 256  # IODE = 8 LSBs of IODC (Sec. 20.3.4.4)
    return values


def encode_frame_start(t0: int, data: dict, tail=(0, 0)):
    """Subframes 1-3 starting at t0 (a frame start), parity chained across them."""
    out = []
    for k in range(3):
        sent = encode_subframe(source_bits(t0 + 6 * k, data), *tail)
        tail = (sent[-2], sent[-1])
        out.append(sent)
    return out


@pytest.mark.parametrize("seed", range(5))
def test_every_word_passes_the_independent_parity_check_and_fields_round_trip(seed):
    rng = np.random.default_rng(seed)
    data = random_data_set(rng)
    t0 = 30 * int(rng.integers(0, 20160))  # a frame start within the week
    prev = (0, 0)
    inverted_words = 0
    for k, sent in enumerate(encode_frame_start(t0, data)):
        for w in range(10):
            word = _bits_to_int(sent[30 * w : 30 * w + 30])
            assert independent_parity_ok((prev[0] << 31) | (prev[1] << 30) | word), (k, w)
            assert not independent_parity_ok((prev[0] << 31) | (prev[1] << 30) | (word ^ (1 << (6 + w))))  # the check can fail
            inverted_words += prev[1]
            prev = (word >> 1) & 1, word & 1
            if w in (1, 9):
                assert prev == (0, 0)  # HOW and word 10 end in D29 = D30 = 0
        assert _bits_to_int(sent[:8]) == PREAMBLE  # the TLM is never inverted
        source, ok = decode_subframe(sent)
        assert all(ok)
        fields = read_fields(source)
        assert fields["subframe_id"] == k + 1 and fields["tow17"] == how_tow(t0 + 6 * k)
        for name in FIELDS[k + 1]:
            assert fields[name] == data[name], name
    assert inverted_words > 0  # the chaining really inverted some words


def test_three_iode_copies_agree_and_follow_a_new_data_set():
    rng = np.random.default_rng(7)
    a = random_data_set(rng)
    b = dict(a, iodc=(a["iodc"] + 1) % 1024)
    b["iode"] = b["iodc"] % 256

    def copies(data):
        sf = [read_fields(decode_subframe(s)[0]) for s in encode_frame_start(0, data)]
        return int(sf[0]["iodc"]) % 256, sf[1]["iode"], sf[2]["iode"]

    assert len(set(copies(a))) == 1 and len(set(copies(b))) == 1 and copies(a) != copies(b)


def test_how_tow_and_subframe_id_follow_time():
    assert subframe_id(0) == 1 and subframe_id(24) == 5 and subframe_id(30) == 1
    assert how_tow(0) == 1 and how_tow(604794) == 0  # the next subframe starts the new week
    sent = encode_subframe(source_bits(120, random_data_set(np.random.default_rng(1))))
    assert read_fields(decode_subframe(sent)[0])["tow17"] * 6 == 126


def test_a_flipped_bit_fails_its_word_and_values_out_of_range_are_refused():
    data = random_data_set(np.random.default_rng(3))
    sent = encode_subframe(source_bits(6, data))
    sent[100] ^= 1  # word 4
    assert decode_subframe(sent)[1] == [True, True, True, False, True, True, True, True, True, True]
    with pytest.raises(ValueError, match="does not fit"):
        source_bits(6, dict(data, c_rs=2.0e4))
    with pytest.raises(ValueError, match="only subframes 1-3"):
        source_bits(18, data)


def test_decode_subframe_equals_reading_bit_by_bit_and_rejects_other_values():
    """The one-integer read gives the words, data and verdicts of the bit-by-bit _get/_put form."""
    import random

    from scintrack.signals.gps import lnav

    def bit_by_bit(sent, d29s, d30s):
        source, ok = [0] * lnav.SUBFRAME_BITS, []
        for w in range(10):
            word = lnav._get(sent, 30 * w + 1, 30)
            data24, good = lnav.decode_word(word, d29s, d30s)
            lnav._put(source, 30 * w + 1, 24, data24)
            ok.append(good)
            d29s, d30s = (word >> 1) & 1, word & 1
        return source, ok

    rng = random.Random(7)
    for _ in range(300):
        sent = [rng.getrandbits(1) for _ in range(lnav.SUBFRAME_BITS)]
        d29s, d30s = rng.getrandbits(1), rng.getrandbits(1)
        expected = bit_by_bit(sent, d29s, d30s)
        assert lnav.decode_subframe(sent, d29s, d30s) == expected
        assert lnav.decode_subframe(np.array(sent, dtype=np.int64), d29s, d30s) == expected
    for value in (2, 49, -1, 0.5):
        with pytest.raises(lnav.LNAVDecodeError, match="0 or 1"):
            lnav.decode_subframe([value] + [0] * (lnav.SUBFRAME_BITS - 1))
