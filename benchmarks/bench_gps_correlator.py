"""E/P/L correlator model speed (M correlator evaluations per second, one core).

    .venv/bin/python benchmarks/bench_gps_correlator.py [--trials 100] [--seconds 240] [--svs 1] [--chunk 10]

Target of the jammed GPS dataset: 4 min x 4 satellites x 100 trials at 1 ms
(96 M E/P/L evaluations, noise included).  Work is done per satellite-batch
(all trials of one satellite) in chunks of ``--chunk`` trials with reused
buffers, as a tracker would.  Timed separately:

* noise: :meth:`NoiseStream.epochs` (seeded blocks + Cholesky mixing);
* numba: a compiled loop calling :func:`epl` once per (trial, epoch), i.e.
  what a tracker kernel does inside its own loop;
* numpy: :func:`correlate` on the whole chunk (allocates its output).

The first call of each path (JIT compilation or cache load) is excluded.
"""

from __future__ import annotations

import argparse
import time

# first: importing scintrack points numba's cache at the package's versioned folder (scintrack.numba_cache);
# numba imported before it would use __pycache__, checked against each kernel's own file only (stale kernels)
import scintrack  # noqa: F401

# isort: split
import numpy as np
from numba import njit

from scintrack.signals.gps.correlator import NoiseStream, amplitude, correlate, epl

T = 1e-3
FULL = 4 * 100 * 240_000  # 4 min x 4 sv x 100 trials at 1 ms


@njit(cache=True)
def _loop(a, d, dtau, dphi, df, T, spacing, noise, out):
    for t in range(noise.shape[0]):
        for k in range(noise.shape[1]):
            epl(a, d[k], dtau[t, k], dphi[t, k], df[t, k], T, spacing, noise[t, k], out[t, k])


def run(trials: int = 100, seconds: float = 240.0, svs: int = 1, chunk: int = 10, spacing: float = 1.0, log=print) -> list[dict]:
    """Rows (benchmark, item, rate, unit, ratio, baseline, ...) of the noise stream, the numba loop and numpy."""
    n = int(round(seconds / T))
    chunk = min(chunk, trials)
    stream = NoiseStream(1, "bench-gps-correlator", spacing)
    rng = np.random.default_rng(0)
    a = float(amplitude(40.0, T))
    d = np.repeat(rng.choice([-1.0, 1.0], -(-n // 20)), 20)[:n]
    dtau = rng.uniform(-0.2, 0.2, (chunk, n))
    dphi = rng.uniform(-0.5, 0.5, (chunk, n))
    df = rng.uniform(-20.0, 20.0, (chunk, n))
    noise = np.empty((chunk, n, 6))
    out = np.empty((chunk, n, 6))
    stream.epochs(list(range(chunk)), 0, 0, n, out=noise)  # touch the buffers
    out[:] = 0.0
    _loop(a, d, dtau[:1, :10], dphi[:1, :10], df[:1, :10], T, spacing, noise[:1, :10], out[:1, :10])  # compile / load

    times = {"noise": 0.0, "numba": 0.0, "numpy": 0.0}
    evals = 0
    for sv in range(svs):
        for t0 in range(0, trials, chunk):
            ids = list(range(t0, min(t0 + chunk, trials)))
            m = len(ids)
            s = time.perf_counter()
            stream.epochs(ids, sv, 0, n, out=noise[:m])
            times["noise"] += time.perf_counter() - s
            s = time.perf_counter()
            _loop(a, d, dtau[:m], dphi[:m], df[:m], T, spacing, noise[:m], out[:m])
            times["numba"] += time.perf_counter() - s
            s = time.perf_counter()
            ref = correlate(a, d, dtau[:m], dphi[:m], df[:m], T, spacing, noise[:m])
            times["numpy"] += time.perf_counter() - s
            evals += m * n
        assert np.allclose(ref, out[: len(ref)], rtol=0, atol=1e-12)
    log(f"{svs} satellite-batch(es) x {trials} trials x {n} epochs = {evals / 1e6:.1f} M E/P/L evaluations, one thread")
    log(f"{'path':28s} {'M eval/s':>9s} {'s per sat-batch':>16s}")
    for name, label in (("noise", "noise (NoiseStream.epochs)"), ("numba", "numba epl loop"), ("numpy", "numpy correlate")):
        log(f"{label:28s} {evals / times[name] / 1e6:9.2f} {times[name] / svs:16.2f}")
    total = times["noise"] + times["numba"]
    log(f"{'noise + numba':28s} {evals / total / 1e6:9.2f} {total / svs:16.2f}")
    log(f"projected noise + numba for 4 min x 4 sv x 100 trials ({FULL / 1e6:.0f} M): {FULL / (evals / total):.1f} s")
    rate = {key: evals / value / 1e6 for key, value in times.items()}
    unit = "M E/P/L evaluations/s"
    return [
        dict(benchmark="gps_correlator", item="noise (NoiseStream.epochs)", rate=rate["noise"], unit=unit),
        dict(benchmark="gps_correlator", item="numba epl loop", rate=rate["numba"], unit=unit, ratio=rate["numba"] / rate["numpy"], baseline="numpy correlate"),
        dict(benchmark="gps_correlator", item="numpy correlate", rate=rate["numpy"], unit=unit, ratio=1.0, baseline="numpy correlate"),
        dict(benchmark="gps_correlator", item="noise + numba", rate=evals / total / 1e6, unit=unit,
             note=f"projected for 4 min x 4 sv x 100 trials ({FULL / 1e6:.0f} M): {FULL / (evals / total):.1f} s"),
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--seconds", type=float, default=240.0, help="signal duration per trial")
    ap.add_argument("--svs", type=int, default=1, help="satellite-batches to run")
    ap.add_argument("--chunk", type=int, default=10, help="trials per chunk")
    ap.add_argument("--spacing", type=float, default=1.0)
    args = ap.parse_args()
    run(args.trials, args.seconds, args.svs, args.chunk, args.spacing)


if __name__ == "__main__":
    main()
