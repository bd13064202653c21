"""Speed of the CSM generator and of the AR fits (prints figures, asserts nothing).

    .venv/bin/python benchmarks/bench_csm_ar.py [--repeat 3]

Reports the best of ``--repeat`` runs:
* CSM output samples per second (10 ms epochs, Nspa = 8), batched over trials;
* seconds to fit AR(1..8), the PACF and the orders for one 300 s series.
"""

from __future__ import annotations

import argparse
import time

from scintrack.models.ar import fit_orders, ic_order, pacf_order, pacf_with_bound
from scintrack.signals.csm import generate_csm


def best_of(repeat: int, func) -> float:
    times = []
    for _ in range(max(repeat, 1)):
        t0 = time.perf_counter()
        func()
        times.append(time.perf_counter() - t0)
    return min(times)


def run(trials: int = 16, epochs: int = 30_000, repeat: int = 3, log=print) -> list[dict]:
    """Rows (benchmark, item, rate, unit, ...) of the CSM generator and of one series' AR fits."""
    t = best_of(repeat, lambda: generate_csm(seed=1, name="bench", trials=range(trials), n_epochs=epochs, ts=0.01, s4=0.8, tau0=0.2))
    rate = trials * epochs / t / 1e6
    log(f"CSM generator: {trials} trials x {epochs} epochs in {t:.3f} s = {rate:.2f} M output samples/s")
    rows = [dict(benchmark="csm_ar", item=f"CSM generator ({trials} trials x {epochs} epochs)", rate=rate, unit="M output samples/s")]
    x = generate_csm(seed=1, name="bench", trials=[0], n_epochs=epochs, ts=0.01, s4=0.8, tau0=0.2).theta[0]

    def fit_one():
        fits = fit_orders(x, 8, "n")
        pacf_order(*pacf_with_bound(x, 12))
        ic_order(fits, "aic")
        ic_order(fits, "bic")

    t = best_of(repeat, fit_one)
    log(f"AR(1..8) + PACF + AIC/BIC on one {epochs}-sample series: {t:.3f} s")
    log(f"  full grid (10 S4 x 8 tau0 x 4 trials x 2 components): ~{t * 640:.0f} CPU s")
    rows.append(dict(benchmark="csm_ar", item=f"AR(1..8) + PACF + AIC/BIC fit ({epochs}-sample series)", rate=1.0 / t, unit="series/s",
                     note=f"full grid (640 series): ~{t * 640:.0f} CPU s"))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    run(repeat=args.repeat)


if __name__ == "__main__":
    main()
