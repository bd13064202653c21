"""The compiled complex second-order filter gives scipy.signal.lfilter's values, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from scintrack.signals import csm, iir


def _bits(v):
    """The bits of every value, any NaN as one NaN: where an infinity in the input makes a NaN, its sign bit
    follows the instructions the compiler chose (x86 propagates an operand's NaN), not the arithmetic."""
    v = np.array(v, dtype=complex if np.iscomplexobj(v) else float)
    f = v.view(np.float64)
    f[np.isnan(f)] = np.nan
    return v.view(np.uint64)


def _rows(rng, rows, n):
    """Complex rows over many magnitudes, with exact zeros of either sign, an infinity and a NaN."""
    x = (rng.normal(size=(rows, n)) + 1j * rng.normal(size=(rows, n))) * np.exp(rng.uniform(-300, 300, (rows, n)))
    x.flat[::37] = 0.0
    x.real.flat[::53] = -0.0
    x.imag.flat[::41] = -0.0
    if n > 100:
        x[0, 50] = np.inf
        x[-1, 60] = complex(np.nan, 1.0)
    return x


def _filters():
    b, a = csm.butterworth(0.3, 0.01 / 8)
    cases = [csm.butterworth(tau0, ts) for tau0 in (0.1, 0.4, 1.0) for ts in (0.01 / 8, 0.001 / 8)]  # a0 = 1: no divisions
    cases += [(3 * b, 3 * a), (b * (1 + 2j), a * (0.5 - 1j)), (b[:2], a), (b, a[:2]), (np.array([0.2, 0.1, 0.05]), np.array([2.0, -0.3, 0.1]))]
    cases += [(b * (1 + 2j), a * np.array([1.0, 1 - 0.5j, 1 + 0.3j]))]  # complex, a0 = 1: the path without divisions
    return cases


@pytest.mark.parametrize("rows", [1, 3, 4, 5, 9])
def test_lfilter_is_scipys_bit_for_bit(rows):
    rng = np.random.default_rng(rows)
    for b, a in _filters():
        for n in (1, 7, 1500):
            x = _rows(rng, rows, n)
            assert np.array_equal(_bits(iir.lfilter(b, a, x)), _bits(signal.lfilter(b, a, x, axis=-1))), (b, a, n)
            zi = rng.normal(size=(rows, 2)) + 1j * rng.normal(size=(rows, 2))
            y, zf = iir.lfilter(b, a, x, zi=zi)
            y_ref, zf_ref = signal.lfilter(b, a, x, axis=-1, zi=zi)
            assert np.array_equal(_bits(y), _bits(y_ref)) and np.array_equal(_bits(zf), _bits(zf_ref)), (b, a, n)
            # a strided view (the time-varying CSM filters column slices of its noise)
            assert np.array_equal(_bits(iir.lfilter(b, a, x[:, 1:])), _bits(signal.lfilter(b, a, x[:, 1:], axis=-1)))


def test_other_filters_and_inputs_go_to_scipy():
    rng = np.random.default_rng(0)
    x = _rows(rng, 3, 200)
    for b, a, xx in ((np.array([1.0]), np.array([1.0, -0.5]), x),  # two coefficients: scipy's loop for them
                     (np.array([1.0, 0.2, 0.1, 0.05]), np.array([1.0, -0.5, 0.1, 0.01]), x),  # four
                     (*csm.butterworth(0.3, 0.01 / 8), x.real),  # real input
                     (*csm.butterworth(0.3, 0.01 / 8), x[0])):  # one row, 1-D
        assert np.array_equal(_bits(iir.lfilter(b, a, xx)), _bits(signal.lfilter(b, a, xx, axis=-1)))


def test_csm_rows_are_the_same_in_any_filter_grouping(monkeypatch):
    """A realisation's rows do not depend on the filter's groups of rows or on the blocks they are streamed in."""
    from scintrack.signals import row_blocks

    kw = dict(seed=5, name="grouping", trials=list(range(7)), n_epochs=900, ts=0.01, s4=0.8, tau0=0.2, warmup=100)
    whole = csm.generate_csm(**kw).z  # one block of 7 rows: a group of 4, then 3 one at a time
    assert np.array_equal(_bits(csm.generate_csm(**{**kw, "trials": [3]}).z[0]), _bits(whole[3]))  # alone
    monkeypatch.setattr(row_blocks, "CHUNK_BYTES", 16 * 8 * 1000 * 2)  # two rows per block, read at call time
    assert csm.filter_chunks(7, 8000) == [(0, 4), (4, 7)] and len(csm.trial_chunks(4, 8000)) == 2
    assert np.array_equal(_bits(csm.generate_csm(**kw).z), _bits(whole))
    segs = [csm.Segment(0.0, 0.8, 0.2), csm.Segment(4.0, 0.5, 0.4)]
    prof = dict(seed=5, name="grouping-p", trials=list(range(7)), n_epochs=900, ts=0.01, segments=segs, warmup=100)
    small = csm.generate_csm_profile(**prof)[0].z
    monkeypatch.setattr(row_blocks, "CHUNK_BYTES", 1 << 30)
    assert np.array_equal(_bits(csm.generate_csm_profile(**prof)[0].z), _bits(small))
