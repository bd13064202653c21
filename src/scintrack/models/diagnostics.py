"""Spectral and PACF diagnostics of the AR fits (data behind Figs. 1-4).

For one realisation of a training dataset, computes the empirical PSD with
``scipy.signal.welch`` and the model PSDs of the per-trial AR fits (the
``trial_*`` variables of :func:`scintrack.models.lut.fit_training_set`; no
refit), plus the PACF and its 95% band.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr
from scipy import signal

from .ar import ar_psd
from .lut import COMPONENTS


def ar_diagnostics(
    train: xr.Dataset,
    fits: xr.Dataset,
    *,
    s4: float,
    tau0: float,
    trial: int,
    orders: Sequence[int],
    nperseg: int,
    case: str,
) -> xr.Dataset:
    """PSDs (empirical and AR models) and PACF for one case, dims (component, ...)."""
    ts = float(train.attrs["ts"])
    fs = 1.0 / ts
    point = train.sel(tau0=tau0, trial=trial)
    fit = fits.sel(s4=s4, tau0=tau0, trial=trial)
    psd_emp, psd_ar, pacf, bound = [], [], [], []
    freqs = None
    for comp in COMPONENTS:
        x = np.asarray(point[comp].values, dtype=float)
        freqs, pxx = signal.welch(x, fs=fs, nperseg=nperseg, detrend="constant")
        psd_emp.append(pxx)
        rows = []
        for order in orders:
            f = fit.sel(component=comp, order=order)
            rows.append(ar_psd(f["trial_coef"].values[:order], float(f["trial_sigma2"].values), freqs, fs))
        psd_ar.append(rows)
        pacf.append(fit["trial_pacf"].sel(component=comp).values)
        bound.append(fit["trial_pacf_bound"].sel(component=comp).values)
    ds = xr.Dataset(
        {
            "psd_empirical": (("component", "freq"), np.array(psd_emp), {"long_name": "Welch PSD of the CSM series", "units": "1/Hz (amplitude), rad2/Hz (phase)"}),
            "psd_ar": (("component", "order", "freq"), np.array(psd_ar), {"long_name": "PSD of the fitted AR model", "units": "1/Hz (amplitude), rad2/Hz (phase)"}),
            "pacf": (("component", "pacf_lag"), np.array(pacf), {"long_name": "sample partial autocorrelation", "units": "1"}),
            "pacf_bound": (("component", "pacf_lag"), np.array(bound), {"long_name": "95% band half-width", "units": "1"}),
        },
        coords={
            "component": list(COMPONENTS),
            "order": list(orders),
            "freq": ("freq", freqs, {"units": "Hz", "long_name": "frequency"}),
            "pacf_lag": fits["pacf_lag"].values,
        },
    )
    ds = ds.expand_dims(case=[case])
    ds["s4"] = ("case", [s4])
    ds["tau0"] = ("case", [tau0])
    return ds
