"""Bit synchronisation from the data: where the 20-ms LNAV bit edges fall among the 1-ms prompts.

With the carrier loop in lock, the in-phase prompt of each code period
carries the data level: it changes sign only at a bit edge (or, rarely at
usable C/N0, through noise).  LNAV bits last 20 code periods and their edges
fall on code epochs (IS-GPS-200 Sec. 3.3.4), so every data transition falls
on one epoch index modulo 20.  This module takes the sign changes of the
prompts, histograms their epoch indices modulo 20 and calls the fullest bin
the bit-edge offset (the histogram method of bit synchronisation; Van
Dierendonck in Parkinson & Spilker, vol. I, ch. 8).  No truth is used.

* A sign change "at epoch k" means ``sign(I_k) != sign(I_{k-1})``: epoch k is
  the first epoch of a new bit, so the bit edge lies at the start of epoch k.
* ``confidence`` is the fraction of all sign changes that fall on the chosen
  offset: 1 when every change is a data transition, lower when noise flips
  signs (a noise flip inside a bit gives two changes off the offset).
* ``edges`` lists the epochs on the offset where the sign changed (the data
  transitions seen); ``boundaries`` every epoch on the offset (every bit
  start, whether the bit changed or not).
* Only the real part is used: a Costas loop locks with the data on I, up to
  the sign ambiguity, which does not move a sign change.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BIT_MS = 20


@dataclass(frozen=True)
class BitSync:
    """Result of :func:`bit_sync`; epochs are indices into the prompts given."""

    offset: int | None  # epoch index modulo 20 of the bit edges (None: no sign change seen)
    confidence: float  # fraction of the sign changes that fall on ``offset`` (NaN without changes)
    histogram: np.ndarray  # (20,) sign changes per epoch index modulo 20
    edges: np.ndarray  # epochs on the offset where the prompt changed sign (data transitions)
    boundaries: np.ndarray  # every epoch on the offset within the prompts (bit starts)

    @property
    def n_changes(self) -> int:
        return int(self.histogram.sum())


def sign_changes(prompts: np.ndarray) -> np.ndarray:
    """Epochs k >= 1 whose in-phase prompt has the other sign than epoch k - 1's."""
    i = np.real(np.asarray(prompts))
    if i.ndim != 1:
        raise ValueError(f"prompts must be a 1-D array of 1-ms prompts (got shape {i.shape})")
    s = np.signbit(i)
    return np.flatnonzero(s[1:] != s[:-1]) + 1


def bit_sync(prompts: np.ndarray, first_epoch: int = 0) -> BitSync:
    """Bit-edge offset (epoch index modulo 20) from the sign changes of ``prompts[first_epoch:]``.

    ``first_epoch`` excludes the loop's pull-in (its sign changes are not data); indices
    in the result refer to the whole ``prompts`` array.
    """
    prompts = np.asarray(prompts)
    if not 0 <= first_epoch < max(prompts.shape[-1], 1):
        raise ValueError(f"first_epoch must lie within the {prompts.shape[-1]} prompts (got {first_epoch})")
    changes = sign_changes(prompts[first_epoch:]) + first_epoch
    histogram = np.bincount(changes % BIT_MS, minlength=BIT_MS)
    if changes.size == 0:
        return BitSync(None, float("nan"), histogram, changes, np.zeros(0, dtype=np.int64))
    offset = int(np.argmax(histogram))
    boundaries = np.arange(first_epoch + (offset - first_epoch) % BIT_MS, prompts.shape[-1], BIT_MS)
    return BitSync(offset, float(histogram[offset] / changes.size), histogram, changes[changes % BIT_MS == offset], boundaries)
