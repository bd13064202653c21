"""Peak double-precision flop rate of one core, estimated from the CPU (for flop-limited bounds).

``peak = FMA units x doubles per vector x 2 flops x clock``:

* doubles per vector from the instruction set the CPU reports (``/proc/cpuinfo``
  flags): 8 with AVX-512, 4 with AVX2/AVX, 2 otherwise (SSE2);
* 2 FMA units per core (an assumption: true of recent x86 server cores, e.g.
  AMD Zen 4/5, Intel Skylake-SP and later; kernels that do not fuse (no FMA
  contraction, as ours) reach the same 2 x width x 2 flops/cycle only where
  multiplies and adds issue on separate pipes, as on Zen 4/5);
* the clock measured here, from a chain of dependent integer multiply + xor
  (4 cycles each on current x86: imul 3, xor 1), because a VM often reports
  only its TSC frequency (``cpu MHz``) and not the boost clock the core runs at.
"""

from __future__ import annotations

import functools
import platform
import time
from dataclasses import dataclass

# first: importing scintrack points numba's cache at the package's versioned folder (scintrack.numba_cache);
# numba imported before it would use __pycache__, checked against each kernel's own file only (stale kernels)
import scintrack  # noqa: F401

# isort: split
import numpy as np
from numba import njit

FMA_UNITS = 2
CHAIN_CYCLES = 4  # imul (3) + xor (1), dependent


@njit(cache=True)
def _chain(n, a):
    x = a
    for i in range(n):
        x = (x * a) ^ i
    return x


def measured_ghz(n: int = 100_000_000, repeat: int = 3) -> float:
    _chain(10, np.int64(3))
    best = min(_timed(n) for _ in range(repeat))
    return CHAIN_CYCLES * n / best / 1e9


def _timed(n: int) -> float:
    t0 = time.thread_time()  # CPU time: the clock of the core while it runs this thread (the machine may be shared)
    _chain(n, np.int64(3))
    return time.thread_time() - t0


def cpu_flags() -> set[str]:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


@dataclass(frozen=True)
class Peak:
    model: str
    isa: str
    doubles: int
    ghz: float

    @property
    def flops_per_cycle(self) -> int:
        return FMA_UNITS * self.doubles * 2

    @property
    def flops(self) -> float:
        return self.flops_per_cycle * self.ghz * 1e9

    def describe(self) -> str:
        return (f"peak {self.flops / 1e9:.0f} Gflop/s/core = {FMA_UNITS} FMA units x {self.doubles} doubles ({self.isa}) x 2 flops "
                f"x {self.ghz:.2f} GHz (clock measured: dependent imul+xor chain, {CHAIN_CYCLES} cycles/step); CPU: {self.model}")


@functools.lru_cache(maxsize=1)
def peak() -> Peak:
    flags = cpu_flags()
    isa, doubles = ("AVX-512", 8) if "avx512f" in flags else ("AVX2", 4) if "avx2" in flags else ("AVX", 4) if "avx" in flags else ("SSE2", 2)
    return Peak(cpu_model(), isa, doubles, measured_ghz())


if __name__ == "__main__":
    print(peak().describe())
