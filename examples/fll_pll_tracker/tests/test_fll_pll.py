"""The example plug-in: the scintrack conformance check, and that the FLL pulls in a frequency error."""

import numpy as np
import pytest
from fll_pll_tracker.tracker import FllAssistedPll

from scintrack.testing import check_tracker
from scintrack.trackers.base import TrackInit
from scintrack.trackers.pll import PLL


@pytest.mark.parametrize("spec", [{}, {"bandwidth_hz": 5.0, "fll_bandwidth_hz": 1.0}])
def test_conforms_to_the_tracker_protocol(spec):
    report = check_tracker("example_fll_pll", spec)
    assert report["reference_checked"]
    assert report["tracking_keys_read"] == ([] if "bandwidth_hz" in spec else ["pll_bandwidth_hz"])


def test_the_fll_pulls_in_a_frequency_error_the_pll_alone_does_not():
    """Clean 45-dB-Hz prompts at 10 ms, acquisition Doppler 20 Hz off: over the last 2 of 6 s the FLL-assisted loop's
    frequency is within 0.2 Hz of the truth; scintrack's third-order PLL with the same Bn ends elsewhere."""
    ts, k, n = 0.01, 600, 3
    t = np.arange(k) * ts
    rng = np.random.default_rng(1)
    sigma = np.sqrt(1 / (2 * 10**4.5 * ts))
    y = np.exp(1j * 2 * np.pi * 20.0 * t)[None, :] + sigma * (rng.standard_normal((n, k)) + 1j * rng.standard_normal((n, k)))
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 40.0), rate_hz_s=np.zeros(n))
    assisted = FllAssistedPll(ts=ts, bandwidth_hz=5.0, fll_bandwidth_hz=2.0).run(y, init).extras["frequency_hz"]
    alone = PLL(ts=ts, bandwidth_hz=5.0).run(y, init).extras["frequency_hz"]
    assert np.all(np.abs(assisted[:, 400:].mean(axis=1) - 20.0) < 0.2)
    assert np.all(np.abs(alone[:, 400:].mean(axis=1) - 20.0) > 5.0)
