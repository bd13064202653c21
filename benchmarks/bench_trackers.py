"""Tracker speed in filter-epochs per second (trials x epochs / wall second).

    .venv/bin/python benchmarks/bench_trackers.py [--trials 500] [--epochs 5000]

For each tracker, on one core: the compiled kernel (what the pipeline runs),
the vectorised textbook numpy reference (``tracker.reference``), and a plain
per-trial loop of that reference (one trial at a time) as the baseline;
ratios are printed.  The
first kernel call (JIT compilation or cache load) is excluded.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from scintrack.models.ar import ScintillationAR
from scintrack.signals.correlator import complex_noise, noise_power, prompts
from scintrack.signals.dynamics import third_order_phase
from scintrack.trackers.aekf_ar import AEKFAR
from scintrack.trackers.base import TrackInit
from scintrack.trackers.kf import DiscriminatorKF
from scintrack.trackers.pll import PLL
from scintrack.trackers.susi_kf import SusiKF

TS = 0.01


def timed(func) -> float:
    t0 = time.perf_counter()
    func()
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=500)
    ap.add_argument("--epochs", type=int, default=5000)
    ap.add_argument("--loop-trials", type=int, default=10, help="trials timed in the per-trial baseline")
    args = ap.parse_args()
    n, k = args.trials, args.epochs
    rng = np.random.default_rng(0)
    thd = third_order_phase(rng.uniform(-np.pi, np.pi, n), k, TS, 50.0, 100.0)
    y = prompts(thd + np.cumsum(rng.normal(0, 0.02, (n, k)), axis=1), 1.0, complex_noise(1, "bench", range(n), k, noise_power(30.0, TS)))
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 50.0), rate_hz_s=np.zeros(n))
    sev = ScintillationAR.from_coefs([0.999], [2.1, -1.5, 0.38], kappa=0.02, sigma2_theta=0.05, sigma2_rho=1e-3, s4=0.9)
    mod = ScintillationAR.from_coefs([1.96, -0.963], [2.35, -1.74, 0.39], kappa=1e-3, sigma2_theta=1.4e-5, sigma2_rho=1e-4, s4=0.5)
    trackers = {
        "PLL": PLL(ts=TS, bandwidth_hz=10.0),
        "KF": DiscriminatorKF(ts=TS, q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4)),
        "AKF": DiscriminatorKF(ts=TS, q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4), adaptive_r=True),
        "AKF-AR": DiscriminatorKF(ts=TS, q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4), adaptive_r=True, ar_coefs=mod.phase.coefs, ar_sigma2=mod.phase.sigma2),
        "AEKF-AR": AEKFAR(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=[ScintillationAR.no_scintillation(), mod, sev], adaptive=True, nominal_noise=0.1),
        # Susi 2014 (here at Ts = 10 ms; the SAKF refreshes Phi3 / T, p every 0.1 s from the last 3 s)
        "AKF PLL": SusiKF(ts=TS, clock="ocxo", q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4), discriminator="atan2"),
        "SAKF PLL": SusiKF(ts=TS, clock="ocxo", q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4), discriminator="atan2", scintillation=True),
    }
    print(f"{n} trials x {k} epochs, one process, single thread")
    print(f"{'tracker':8s} {'kernel M/s':>11s} {'numpy-ref M/s':>14s} {'per-trial loop M/s':>19s} {'kernel/loop':>12s}")
    for name, tr in trackers.items():
        tr.run(y[:2, :10], TrackInit(init.phase[:2], init.doppler_hz[:2], init.rate_hz_s[:2]))  # compile / load cache
        t_kernel = timed(lambda: tr.run(y, init))
        m = min(n, 100)
        t_vec = timed(lambda: tr.reference(y[:m], TrackInit(init.phase[:m], init.doppler_hz[:m], init.rate_hz_s[:m])))
        L = args.loop_trials
        t_loop = timed(lambda: [tr.reference(y[i : i + 1, : k // 5], TrackInit(init.phase[i : i + 1], init.doppler_hz[i : i + 1], init.rate_hz_s[i : i + 1])) for i in range(L)])
        r_kernel, r_vec, r_loop = n * k / t_kernel / 1e6, m * k / t_vec / 1e6, L * (k // 5) / t_loop / 1e6
        print(f"{name:8s} {r_kernel:11.2f} {r_vec:14.2f} {r_loop:19.3f} {r_kernel / r_loop:11.0f}x")


if __name__ == "__main__":
    main()
