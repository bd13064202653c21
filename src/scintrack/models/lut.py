"""AR look-up table over the (S4, tau0) grid, read by the trackers.

:func:`fit_training_set` fits AR(1..max_order) models, the PACF and the
selected orders (PACF / AIC / BIC) to every realisation of one CSM training
dataset; :func:`merge_lut` stacks the per-S4 fits into one table and adds the
trial averages that trackers use; :func:`lookup` returns the :class:`~.ar.ArModel` of one component at the
nearest grid point and :func:`scintillation_ar` the phase/amplitude pair the
trackers use (orders from Table I).

Nearest-point look-ups.  :func:`nearest_point` is the one rule (xarray's
``sel(method="nearest")`` per axis) by which a requested (S4, tau0) becomes a
grid point; :func:`grid_of` makes a table-less grid from the config
(``ar_training.s4/tau0``) so that :mod:`scintrack.validity` applies the same
rule before anything runs.  A look-up is *on the grid* when the nearest point
is within :data:`LOOKUP_TOL_S4` (0.005 in S4, half the 0.01 to which the
configs give S4) and :data:`LOOKUP_TOL_TAU0` (1 % of the requested tau0) of
the requested one (:func:`within_tolerance`): the grid point then stands for
it up to how the config writes numbers.  Anything further is refused at
config time (:func:`scintrack.validity.check_model_ranges`), since the
trackers and ``scintillation_model: ar`` scenarios would silently use a
different model (S4 = 1.5 used the S4 = 1 models, realising 0.77).  The
point actually used is :attr:`ScintillationAR.s4` / ``tau0`` of the returned
models (a tracker's ``design_point``; a scenario's ``Realisation.model_point``).
:func:`scintillation_ar` itself still takes the nearest point for any
request (library use, e.g. the AR-order study), the refusal is the config's.

Layout of the table (NetCDF, CF-style attributes):

* ``coef(s4, tau0, component, order, lag)``: trial-mean AR coefficients of the
  AR(``order``) fit, zero beyond ``lag > order`` (gamma_i for the amplitude,
  beta_i for the phase);
* ``const(s4, tau0, component, order)``: kappa (0 for the phase);
* ``sigma2(s4, tau0, component, order)``: driving-noise variance;
* ``selected_order(s4, tau0, component, criterion)``: modal order over trials;
* the same per trial with the ``trial_`` prefix, and the PACF with its band.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from ..progress import Progress
from .ar import TRENDS, ArModel, ScintillationAR, fit_orders, ic_order, pacf_order, pacf_with_bound
from .regions import region_of

COMPONENTS = ("amplitude", "phase")
CRITERIA = ("pacf", "aic", "bic")


def fit_training_set(
    train: xr.Dataset, max_order: int, pacf_lags: int, alpha: float, pacf_lengths_s: Sequence[float] = (), wrap_phase: bool = False,
    reuse: xr.Dataset | None = None, progress=None,
) -> xr.Dataset:
    """Per-trial AR fits of one training dataset with dims (tau0, trial, time).

    ``wrap_phase``: fit the phase models on the wrapped phase ``angle(exp(j theta))``
    instead of the stored unwrapped one (reading R5 of the Vila-Valls simulation).
    ``reuse``: the unwrapped fits of the same training set and settings; with
    ``wrap_phase`` their amplitude component is copied instead of refitted (the
    amplitude series is the same, so are its fits).
    ``progress``: where to write progress lines (series fitted, rate, ETA).

    ``pacf_lengths_s`` adds the PACF-rule order measured on the first
    ``L`` seconds of each series (the 95% band widens as 1/sqrt(N)), to show
    how the selected order depends on the length of the data.
    """
    ts = float(train.attrs["ts"])
    lengths = [L for L in pacf_lengths_s if int(round(L / ts)) <= train.sizes["time"]]
    tau0s = train["tau0"].values
    trials = train["trial"].values
    n_t, n_r, n_c = tau0s.size, trials.size, len(COMPONENTS)
    coef = np.zeros((n_t, n_r, n_c, max_order, max_order))
    const = np.zeros((n_t, n_r, n_c, max_order))
    sigma2 = np.zeros((n_t, n_r, n_c, max_order))
    pacf_v = np.zeros((n_t, n_r, n_c, pacf_lags + 1))
    pacf_b = np.zeros((n_t, n_r, n_c, pacf_lags + 1))
    chosen = np.zeros((n_t, n_r, n_c, len(CRITERIA)), dtype=np.int32)
    by_length = np.zeros((n_t, n_r, n_c, len(lengths)), dtype=np.int32)
    copy = _reusable(reuse, train, max_order, pacf_lags, alpha, lengths) if wrap_phase else None
    prog = Progress(n_t * n_r, unit="realisations", log=progress, label=f"AR fits S4 = {float(train['s4'].values):g}")
    for i in range(n_t):
        for j in range(n_r):
            for c, comp in enumerate(COMPONENTS):
                if copy is not None and comp == "amplitude":
                    sel = copy.isel(tau0=i, trial=j).sel(component=comp)
                    coef[i, j, c], const[i, j, c], sigma2[i, j, c] = sel["trial_coef"].values, sel["trial_const"].values, sel["trial_sigma2"].values
                    pacf_v[i, j, c], pacf_b[i, j, c] = sel["trial_pacf"].values, sel["trial_pacf_bound"].values
                    chosen[i, j, c], by_length[i, j, c] = sel["trial_selected_order"].values, sel["trial_pacf_order_by_length"].values
                    continue
                x = np.asarray(train[comp].values[i, j], dtype=float)
                if wrap_phase and comp == "phase":
                    x = np.angle(np.exp(1j * x))
                trend = TRENDS[comp]
                fits = fit_orders(x, max_order, trend)
                for o, fit in enumerate(fits, start=1):
                    coef[i, j, c, o - 1, :o] = fit.coefs
                    const[i, j, c, o - 1] = fit.const
                    sigma2[i, j, c, o - 1] = fit.sigma2
                values, bound = pacf_with_bound(x, pacf_lags, alpha)
                pacf_v[i, j, c], pacf_b[i, j, c] = values, bound
                chosen[i, j, c] = [
                    pacf_order(values, bound),
                    ic_order(fits, "aic"),
                    ic_order(fits, "bic"),
                ]
                for k, length in enumerate(lengths):
                    n_len = int(round(length / ts))
                    # the whole series: the PACF just computed (same call, same values)
                    by_length[i, j, c, k] = chosen[i, j, c, 0] if n_len >= x.size else pacf_order(*pacf_with_bound(x[:n_len], pacf_lags, alpha))
            prog.add(1)
    coords = {
        "tau0": tau0s,
        "trial": trials,
        "component": list(COMPONENTS),
        "order": np.arange(1, max_order + 1),
        "lag": np.arange(1, max_order + 1),
        "pacf_lag": np.arange(pacf_lags + 1),
        "criterion": list(CRITERIA),
        "pacf_length": ("pacf_length", np.asarray(lengths, dtype=float), {"long_name": "length of the series used for the PACF", "units": "s"}),
    }
    dims = ("tau0", "trial", "component")
    ds = xr.Dataset(
        {
            "trial_coef": (dims + ("order", "lag"), coef, {"long_name": "AR coefficient (gamma_i amplitude, beta_i phase)", "units": "1"}),
            "trial_const": (dims + ("order",), const, {"long_name": "AR constant kappa (amplitude only)", "units": "1"}),
            "trial_sigma2": (dims + ("order",), sigma2, {"long_name": "AR driving-noise variance", "units": "1 (amplitude), rad2 (phase)"}),
            "trial_pacf": (dims + ("pacf_lag",), pacf_v, {"long_name": "sample partial autocorrelation", "units": "1"}),
            "trial_pacf_bound": (dims + ("pacf_lag",), pacf_b, {"long_name": f"half-width of the {100 * (1 - alpha):g}% band of the PACF around 0", "units": "1"}),
            "trial_selected_order": (dims + ("criterion",), chosen, {"long_name": "selected AR order", "units": "1"}),
            "trial_pacf_order_by_length": (dims + ("pacf_length",), by_length, {"long_name": "PACF-rule order on the first pacf_length seconds", "units": "1"}),
        },
        coords=coords,
    )
    ds = ds.expand_dims(s4=[float(train["s4"].values)])
    ds.attrs.update({"pacf_alpha": alpha, "max_order": max_order, "estimator": "statsmodels AutoReg (conditional ML / OLS)", "pacf_method": "statsmodels pacf(method='ols')"})
    return ds


def _reusable(reuse: xr.Dataset | None, train: xr.Dataset, max_order: int, pacf_lags: int, alpha: float, lengths) -> xr.Dataset | None:
    """``reuse`` if it holds the fits of exactly this training set and these settings, else an error (None: nothing given)."""
    if reuse is None:
        return None
    ok = (
        int(reuse.attrs.get("max_order", -1)) == max_order and reuse.sizes.get("pacf_lag") == pacf_lags + 1
        and float(reuse.attrs.get("pacf_alpha", -1)) == alpha and np.array_equal(reuse["tau0"].values, train["tau0"].values)
        and np.array_equal(reuse["trial"].values, train["trial"].values) and float(reuse["s4"].values[0]) == float(train["s4"].values)
        and np.array_equal(reuse["pacf_length"].values, np.asarray(lengths, dtype=float))
    )
    if not ok:
        raise ValueError("the unwrapped fits given for reuse were made from another training set or other ar_models settings")
    return reuse.isel(s4=0)


def _mode(values: np.ndarray, axis: int) -> np.ndarray:
    """Smallest most frequent value along ``axis`` (ties go to the lower order)."""
    moved = np.moveaxis(values, axis, -1)
    out = np.empty(moved.shape[:-1], dtype=values.dtype)
    for idx in np.ndindex(out.shape):
        vals, counts = np.unique(moved[idx], return_counts=True)
        out[idx] = vals[np.argmax(counts)]
    return out


def merge_lut(fits: Sequence[xr.Dataset]) -> xr.Dataset:
    """Combine per-S4 fit datasets into the AR look-up table."""
    lut = xr.concat(list(fits), dim="s4").sortby("s4")
    lut["coef"] = lut["trial_coef"].mean("trial").assign_attrs(lut["trial_coef"].attrs, long_name="trial-mean AR coefficient")
    lut["const"] = lut["trial_const"].mean("trial").assign_attrs(lut["trial_const"].attrs)
    lut["sigma2"] = lut["trial_sigma2"].mean("trial").assign_attrs(lut["trial_sigma2"].attrs)
    sel = lut["trial_selected_order"]
    lut["selected_order"] = (
        ("s4", "tau0", "component", "criterion"),
        _mode(sel.transpose("s4", "tau0", "component", "criterion", "trial").values, axis=-1),
        {"long_name": "modal selected AR order over trials", "units": "1"},
    )
    lut["s4"].attrs.update(long_name="amplitude scintillation index S4", units="1")
    lut["tau0"].attrs.update(long_name="scintillation decorrelation time tau0", units="s")
    return lut


#: AR(p) phase order per scintillation region (Table I of Vila-Valls 2018); amplitude order q.
TABLE_I_PHASE_ORDER = {"severe": 1, "moderate": 2, "low": 3}
AMPLITUDE_ORDER = 3


#: a look-up is on the grid when |S4 - S4_grid| <= this ...
LOOKUP_TOL_S4 = 0.005
#: ... and |tau0 - tau0_grid| <= this fraction of the requested tau0
LOOKUP_TOL_TAU0 = 0.01


def nearest_point(lut: xr.Dataset, s4: float, tau0: float) -> tuple[float, float]:
    """The grid point (S4, tau0) of the table (or of :func:`grid_of`) nearest to (s4, tau0)."""
    return _grid_point(lut, *_nearest_indices(lut, s4, tau0))


def _grid_point(lut: xr.Dataset, i: int, j: int) -> tuple[float, float]:
    """(S4, tau0) of grid position (``i``, ``j``)."""
    return float(lut["s4"].values[i]), float(lut["tau0"].values[j])


def _nearest_indices(lut: xr.Dataset, s4: float, tau0: float) -> tuple[int, int]:
    """Positions of the nearest grid S4 and tau0: the pandas look-up behind ``lut.sel(..., method="nearest")``.

    Called directly, once per model pair, without building selected
    sub-datasets (xarray's ``sel`` takes 3-5 ms a call and a pair would make
    three, twice over: an adaptive AEKF-AR builds ten pairs).  Ties are
    broken as pandas breaks them; a value with no nearest point (NaN) raises
    ``KeyError`` as ``sel`` does.
    """
    i = int(lut.indexes["s4"].get_indexer([s4], method="nearest")[0])
    j = int(lut.indexes["tau0"].get_indexer([tau0], method="nearest")[0])
    if i < 0 or j < 0:
        raise KeyError(f"no grid point nearest to S4 = {s4!r}, tau0 = {tau0!r}")
    return i, j


def grid_of(s4: Sequence[float], tau0: Sequence[float]) -> xr.Dataset:
    """A coordinates-only stand-in for the table on the grid ``s4`` x ``tau0`` (config time: no table yet)."""
    return xr.Dataset(coords={"s4": np.sort(np.asarray(s4, dtype=float)), "tau0": np.sort(np.asarray(tau0, dtype=float))})


def within_tolerance(requested: tuple[float, float], used: tuple[float, float]) -> bool:
    """True when the grid point ``used`` stands for ``requested`` (:data:`LOOKUP_TOL_S4`, :data:`LOOKUP_TOL_TAU0`)."""
    return abs(used[0] - requested[0]) <= LOOKUP_TOL_S4 and abs(used[1] - requested[1]) <= LOOKUP_TOL_TAU0 * requested[1]


def lookup(lut: xr.Dataset, s4: float, tau0: float, component: str, order: int) -> ArModel:
    """AR(``order``) model of ``component`` at the grid point nearest to (s4, tau0)."""
    return _model_at(lut, *_nearest_indices(lut, s4, tau0), component, order)


def _model_at(lut: xr.Dataset, i: int, j: int, component: str, order: int) -> ArModel:
    """AR(``order``) model of ``component`` at grid position (``i``, ``j``) of (S4, tau0)."""
    at = {"s4": i, "tau0": j, "component": lut.indexes["component"].get_loc(component), "order": lut.indexes["order"].get_loc(order)}

    def value(name: str) -> np.ndarray:
        var = lut[name]
        return var.values[tuple(at.get(dim, slice(None)) for dim in var.dims)]

    return ArModel(coefs=value("coef")[:order].copy(), const=float(value("const")), sigma2=float(value("sigma2")))


def scintillation_ar(lut: xr.Dataset, s4: float, tau0: float, phase_order: int | None = None) -> ScintillationAR:
    """Phase AR(p) and amplitude AR(3) of the grid point nearest to (s4, tau0).

    ``p`` follows Table I for the region of ``s4`` unless ``phase_order`` is given.
    """
    p = phase_order or TABLE_I_PHASE_ORDER[region_of(s4)]
    i, j = _nearest_indices(lut, s4, tau0)
    grid_s4, grid_tau0 = _grid_point(lut, i, j)
    return ScintillationAR(
        phase=_model_at(lut, i, j, "phase", p),
        amplitude=_model_at(lut, i, j, "amplitude", AMPLITUDE_ORDER),
        s4=grid_s4, tau0=grid_tau0, label=f"S4={grid_s4:g},tau0={grid_tau0:g},AR({p})/AR(3)",
    )
