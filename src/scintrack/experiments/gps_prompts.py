"""Prompt correlator outputs of the jammed GPS scenario, as a tracking receiver sees them.

The receiver removes the carrier it can predict: the satellite's Doppler from
the last decoded broadcast ephemeris and the surveyed receiver position (the
paper's static GBAS reference receiver: "phi_Dopp ... is known and removed
using the last decoded broadcast ephemeris").  What is left in the prompts
is the residual phase

``phi_res = carrier phase (truth) - predicted carrier phase``

= receiver clock phase + broadcast-ephemeris and satellite-clock prediction
errors + the atmospheric delays the receiver does not model + the unknown
initial phase.  Both carrier trackers (the Costas PLL at 1 ms and the MM
filter on 20-ms sums) track this residual, so they are compared on the same
input.  The 1-ms prompt is the correlator-level model
(:mod:`scintrack.signals.gps.correlator`) with a FIXED-gain front end: the
amplitude stays at its clean value and the noise grows with the jammer, as in
the paper's eq. (9) (a unit-amplitude signal whose noise variance follows
C/N0); an AGC would instead drop the amplitude 31 dB at the onset, which the
MM filter's near-constant amplitude state cannot follow) with the code aligned (the code error of the DLL costs at most
``1 - |dtau|`` of amplitude: 0.1-0.5 dB at the DLL errors measured, left out
and stated) and no intra-interval frequency error (the tracking loop keeps it
below a few Hz: sinc loss < 0.01 dB at 1 ms); the noise comes from the seeded
E/P/L stream per (trial, satellite, block), so a trial's noise is the same
for every tracker and for the DLL, which uses the E and L columns of the same
draws.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr
from numba import njit

from ..signals.gps import geometry
from ..signals.gps.correlator import NoiseStream, gains
from ..signals.gps.ephemeris import Ephemeris
from ..signals.gps.orbit import C_LIGHT
from .lock_detector import lock_state, loss_of_lock_events  # noqa: F401 (the receiver's detector, used through this module)

CODE_PERIOD_S = 1e-3
BIT_MS = 20


def predicted_phase_cycles(eph: Ephemeris, rx_ecef: np.ndarray, t_rx_sow: np.ndarray, lambda_m: float) -> np.ndarray:
    """Carrier phase (cycles) the receiver predicts from a decoded data set: ``-(range - c dt_sv) / lambda``."""
    truth = geometry.signal_truth(eph, rx_ecef, t_rx_sow)
    return -(truth["range_m"] - C_LIGHT * truth["sat_clock_s"]) / lambda_m


def residual_phase(ds: xr.Dataset, k: int, eph: Ephemeris) -> tuple[np.ndarray, np.ndarray]:
    """``phi_res`` (rad) of satellite ``k`` at its code epochs (offset by whole cycles to start in [0, 2 pi)), and its frequency (Hz).

    The frequency is the truth's Doppler minus the predicted one: the smooth part,
    without the receiver clock's white-FM phase noise (which no filter can
    follow and which has no derivative; ``doppler`` of the dataset excludes it).
    """
    rt = ds["receive_time"].isel(sv=k).values
    t_rx = float(ds.attrs["t_start_sow"]) + rt
    lam = C_LIGHT / float(ds.attrs["carrier_hz"])
    pred = predicted_phase_cycles(eph, np.asarray(ds.attrs["receiver_ecef_m"], dtype=float), t_rx, lam)
    res = ds["carrier_phase"].isel(sv=k).values - pred
    freq = ds["doppler"].isel(sv=k).values - np.gradient(pred, rt)
    return 2.0 * np.pi * (res - np.floor(res[0])), freq


def prompts_1ms(stream: NoiseStream, trials: Sequence[int], k: int, phi_res: np.ndarray, cn0_dbhz: np.ndarray, bits: np.ndarray,
                cn0_ref_dbhz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(1-ms prompts (trials, epochs), unit E/P/L noise (trials, epochs, 6), noise scale sigma (epochs,)) of satellite ``k``."""
    noise = stream.epochs(list(trials), k, 0, len(phi_res))
    a, sigma = gains(cn0_dbhz, CODE_PERIOD_S, "fixed", cn0_ref_dbhz)
    signal = a * bits * np.exp(1j * phi_res)
    n = noise.shape[1]
    row = np.broadcast_to(signal, (n,))  # a scalar C/N0 or amplitude gives the same row for every epoch
    y = np.empty(noise.shape[:2], dtype=complex)
    _prompts_kernel(np.ascontiguousarray(row.real), np.ascontiguousarray(row.imag), np.ascontiguousarray(np.broadcast_to(sigma, (n,)), dtype=float), noise, y)
    return y, noise, sigma


@njit(cache=True)
def _prompts_kernel(sr, si, sigma, noise, out):
    """``out[t, e] = (sr[e] + sigma[e] noise[t, e, 1]) + j (si[e] + sigma[e] noise[t, e, 4])`` (IP and QP columns).

    The values of numpy's ``signal + sigma * (noise[..., 1] + 1j * noise[..., 4])``: there each product by
    ``sigma`` is rounded once and the sums are exact
    componentwise, as here (no fused multiply-add: numba does not contract), without its three
    (trials, epochs) complex temporaries.
    """
    n_tr, n_ep = out.shape
    for t in range(n_tr):
        for e in range(n_ep):
            out[t, e] = complex(sr[e] + sigma[e] * noise[t, e, 1], si[e] + sigma[e] * noise[t, e, 4])


def bit_sums(y1: np.ndarray, first_in_bit: int) -> tuple[np.ndarray, int]:
    """20-ms coherent sums aligned with the data-bit edges, and the index of the first epoch used."""
    start = (BIT_MS - first_in_bit) % BIT_MS
    n = (y1.shape[-1] - start) // BIT_MS
    return y1[..., start : start + n * BIT_MS].reshape(*y1.shape[:-1], n, BIT_MS).sum(axis=-1), start


def interval_phase(phi: np.ndarray, start: int, n_bits: int) -> np.ndarray:
    """Phase of the mean phasor over each 20-ms interval (what a 20-ms coherent sum measures), unwrapped."""
    blocks = np.exp(1j * phi[start : start + n_bits * BIT_MS]).reshape(n_bits, BIT_MS).mean(axis=1)
    return np.unwrap(np.angle(blocks))


def wrap(x: np.ndarray, period: float = 2 * np.pi) -> np.ndarray:
    """``x`` wrapped to (-period/2, period/2]."""
    return -((period / 2 - x) % period - period / 2)


