"""Achievability floors (scintrack.experiments.floors): each bound against an independent computation."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl
import xarray as xr
from scipy.signal import lfilter

from scintrack.experiments import floors as fl
from scintrack.models.ar import ScintillationAR
from scintrack.trackers.base import dynamics_F, dynamics_Q

TS, CN0 = 0.01, 30.0
R_PHI = 1.0 / (2 * 10 ** (CN0 / 10) * TS)


def ar1_acf(phi: float, var: float, n: int) -> np.ndarray:
    return var * phi ** np.arange(n)


# --- (a) -----------------------------------------------------------------------------------------


def test_riccati_bound_is_the_mse_of_the_linear_kf():
    """P+[0,0] of the time-varying Riccati recursion equals the empirical MSE of a plain KF on linear-Gaussian data."""
    beta, s2t, gamma, kappa, s2r, q = 0.9, 0.01, 0.95, 0.05, 1e-3, 0.01
    ar = ScintillationAR.from_coefs([beta], [gamma], kappa, s2t, s2r)
    p0 = (0.25, 1.0, 100.0)
    dur, start = 8.0, 4.0
    res = fl.riccati_floor(ar, cn0_dbhz=CN0, ts=TS, q_jerk=q, p0_diag=p0, theta_s_p0=0.01, rho_p0=0.05, duration_s=dur,
                           steady_start_s=start)
    # the same model built here by hand: x = [theta_d, f_d, f_r, theta_s, rho]
    F = sl.block_diag(dynamics_F(TS), [[beta]], [[gamma]])
    Q = sl.block_diag(dynamics_Q(q, TS), [[s2t]], [[s2r]])
    u = np.array([0, 0, 0, 0, kappa])  # known input: the AR constant
    rho0 = kappa / (1 - gamma)
    H = np.array([[0, 0, 0, 0, 1.0], [rho0, 0, 0, rho0, 0]])
    R = 0.5 / (10 ** (CN0 / 10) * TS) * np.eye(2)
    P0 = np.diag([*p0, 0.01, 0.05])
    rng = np.random.default_rng(1)
    n_tr, n_ep = 200, int(round(dur / TS))
    m0 = np.array([0, 50.0, 0, 0, rho0])
    x = m0 + rng.multivariate_normal(np.zeros(5), P0, n_tr)
    xh = np.tile(m0, (n_tr, 1))
    P = P0.copy()
    Lq = np.linalg.cholesky(Q + 1e-30 * np.eye(5))
    err = np.empty((n_tr, n_ep))
    for k in range(n_ep):
        if k > 0:
            x = x @ F.T + u + rng.standard_normal((n_tr, 5)) @ Lq.T
            xh = xh @ F.T + u
            P = F @ P @ F.T + Q
        z = x @ H.T + rng.standard_normal((n_tr, 2)) * np.sqrt(R[0, 0])
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        xh = xh + (z - xh @ H.T) @ K.T
        P = (np.eye(5) - K @ H) @ P
        err[:, k] = xh[:, 0] - x[:, 0]
    w = np.arange(n_ep) * TS >= start
    ms = (err[:, w] ** 2).mean(axis=1)
    theory = res["p_theta_d"][w].mean()
    assert abs(ms.mean() - theory) < 4 * ms.std(ddof=1) / np.sqrt(n_tr)
    assert res["time_varying"] == pytest.approx(np.sqrt(theory))
    # stable AR phase: the DARE exists and the recursion has converged to it
    assert res["steady_state_reason"] == ""
    assert res["steady_state"] == pytest.approx(np.sqrt(res["p_theta_d"][-1]), rel=1e-6)
    assert res["settling_time_s"] < dur


def test_riccati_unit_root_phase_is_not_detectable():
    ar = ScintillationAR.from_coefs([1.0], [0.9], 0.1, 0.01, 1e-3)
    res = fl.riccati_floor(ar, cn0_dbhz=CN0, ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), theta_s_p0=0.01, rho_p0=0.05,
                           duration_s=4.0, steady_start_s=2.0)
    assert np.isnan(res["steady_state"]) and "not detectable" in res["steady_state_reason"]
    assert np.isfinite(res["time_varying"]) and np.all(np.diff(res["p_theta_d"][100:]) > 0)  # random-walk theta_s leaks into theta_d


# --- (b), (c) --------------------------------------------------------------------------------------


def test_gls_floor_matches_brute_force_gls():
    """Polynomial + AR(1) + white noise, GLS by lstsq on whitened data: empirical error variance = formula."""
    dur, start, n = 2.0, 0.5, 200
    acf = ar1_acf(0.9, 0.2, n)
    t_eval, var = fl.gls_error_variance(acf, ts=TS, cn0_dbhz=CN0, duration_s=dur, steady_start_s=start)
    t = np.arange(n) * TS
    X = np.vander(t, 3, increasing=True)
    C = sl.toeplitz(acf) + R_PHI * np.eye(n)
    L = np.linalg.cholesky(C)
    rng = np.random.default_rng(2)
    m = 4000
    a = np.array([0.3, 2 * np.pi * 50, np.pi * 100])  # 50 Hz, 100 Hz/s
    y = (X @ a)[:, None] + L @ rng.standard_normal((n, m))
    a_hat = np.linalg.lstsq(np.linalg.solve(L, X), np.linalg.solve(L, y), rcond=None)[0]
    k = np.round(t_eval / TS).astype(int)
    e = (X @ (a_hat - a[:, None]))[k]
    ms = (e**2).mean(axis=0)
    assert abs(ms.mean() - var.mean()) < 4 * ms.std(ddof=1) / np.sqrt(m)
    ev = (e**2).mean(axis=1)  # per epoch: se of a variance estimate = var sqrt(2/m)
    assert np.all(np.abs(ev[::30] - var[::30]) < 4 * var[::30] * np.sqrt(2 / m))
    assert fl.gls_floor(acf, ts=TS, cn0_dbhz=CN0, duration_s=dur, steady_start_s=start) == pytest.approx(np.sqrt(var.mean()))


def test_gls_with_white_noise_is_ols():
    dur, start = 3.0, 1.0
    t_eval, var = fl.gls_error_variance(np.zeros(300), ts=TS, cn0_dbhz=CN0, duration_s=dur, steady_start_s=start)
    t = np.arange(300) * TS
    _, cov = np.polyfit(t, np.zeros_like(t), 2, cov="unscaled")  # (A^T A)^-1, powers 2, 1, 0
    g = np.vander(t_eval, 3)
    np.testing.assert_allclose(var, R_PHI * np.einsum("ki,ij,kj->k", g, cov, g), rtol=1e-8)


def rts_theta_d_variance(phi: float, var_s: float, q: float, n: int) -> np.ndarray:
    """Fixed-interval (RTS) smoother variance of theta_d for [theta_d, f_d, f_r, theta_s], diffuse dynamics prior,
    theta_s AR(1) stationary, y = theta_d + theta_s + w."""
    F = sl.block_diag(dynamics_F(TS), [[phi]])
    Q = sl.block_diag(dynamics_Q(q, TS), [[var_s * (1 - phi**2)]])
    H = np.array([1.0, 0, 0, 1])
    P = np.diag([1e8, 1e8, 1e8, var_s])
    Pf, Pp = np.empty((n, 4, 4)), np.empty((n, 4, 4))
    for k in range(n):
        if k > 0:
            P = F @ P @ F.T + Q
        Pp[k] = P
        S = H @ P @ H + R_PHI
        K = P @ H / S
        P = P - np.outer(K, K) * S
        Pf[k] = P = 0.5 * (P + P.T)
    out = np.empty(n)
    Ps = Pf[-1]
    out[-1] = Ps[0, 0]
    for k in range(n - 2, -1, -1):
        J = Pf[k] @ F.T @ np.linalg.inv(Pp[k + 1])
        Ps = Pf[k] + J @ (Ps - Pp[k + 1]) @ J.T
        out[k] = Ps[0, 0]
    return out


@pytest.mark.parametrize("q", [0.0, 1.0])
def test_gls_and_kriging_equal_the_kalman_smoother(q):
    """Smoother floor = GLS (q = 0, theta_s estimated jointly) and = universal kriging (q > 0)."""
    n, dur, start, phi, var_s = 1000, 10.0, 3.0, 0.97, 0.3
    t_eval, var = fl.gls_error_variance(ar1_acf(phi, var_s, n), ts=TS, cn0_dbhz=CN0, duration_s=dur, steady_start_s=start, q_jerk=q,
                                        stride=7)
    rts = rts_theta_d_variance(phi, var_s, q, n)
    np.testing.assert_allclose(var, rts[np.round(t_eval / TS).astype(int)], rtol=1e-4)


@pytest.mark.parametrize("q", [1.0, 0.01])
def test_differenced_kriging_equals_the_dense_solve(q):
    """Floor (c) by the third-difference / Toeplitz route = the dense Cholesky of C_s + C_d + R_phi I (strongly
    correlated theta_s with much low-frequency power, as the CSM's unwrapped phase)."""
    n = 1500
    rng = np.random.default_rng(5)
    walk = lfilter([1.0], [1.0, -0.999], rng.standard_normal((20, n + 2000)), axis=1)[:, 2000:]  # slow, as unwrapped phase
    acf = fl.autocovariance(0.1 * walk + lfilter([1.0], [1.0, -0.9], rng.standard_normal((20, n)), axis=1))
    kw = dict(ts=TS, cn0_dbhz=CN0, duration_s=n * TS, steady_start_s=5.0, q_jerk=q, stride=13)
    t1, v1 = fl.gls_error_variance(acf, method="differenced", **kw)
    t2, v2 = fl.gls_error_variance(acf, method="dense", **kw)
    np.testing.assert_array_equal(t1, t2)
    np.testing.assert_allclose(v1, v2, rtol=1e-4)


def test_differenced_kriging_refuses_an_ill_conditioned_g():
    """A tiny q_jerk makes G's low-frequency modes vanish: "auto" falls back to the dense solve, "differenced" says why."""
    acf = ar1_acf(0.99, 1.0, 800)
    kw = dict(ts=TS, cn0_dbhz=CN0, duration_s=8.0, steady_start_s=2.0, q_jerk=1e-6, stride=9)
    with pytest.raises(np.linalg.LinAlgError, match="ill-conditioned"):
        fl.gls_error_variance(acf, method="differenced", **kw)
    np.testing.assert_array_equal(fl.gls_error_variance(acf, **kw)[1], fl.gls_error_variance(acf, method="dense", **kw)[1])


@pytest.mark.parametrize("q", [0.0, 1.0])
def test_constant_offset_adds_its_variance(q):
    """theta_s + c (c ~ N(0, s2), constant over the run) raises every floor's variance by exactly s2."""
    n, s2 = 600, 0.04
    acf = ar1_acf(0.95, 0.2, n)
    kw = dict(ts=TS, cn0_dbhz=CN0, duration_s=6.0, steady_start_s=2.0, q_jerk=q, stride=11)
    _, v0 = fl.gls_error_variance(acf, **kw)
    _, v1 = fl.gls_error_variance(acf + s2, **kw)
    np.testing.assert_allclose(v1, v0 + s2, rtol=1e-6)


def test_thrice_integrated_covariance_matches_discrete_model():
    ts, q, n, m = 0.1, 1.0, 40, 20000
    F, Q = dynamics_F(ts), dynamics_Q(q, ts)
    rng = np.random.default_rng(3)
    L = np.linalg.cholesky(Q)
    x = np.zeros((m, 3))
    th = np.empty((m, n))
    th[:, 0] = 0.0
    for k in range(1, n):
        x = x @ F.T + rng.standard_normal((m, 3)) @ L.T
        th[:, k] = x[:, 0]
    t = np.arange(n) * ts
    C = fl.thrice_integrated_covariance(t, q_jerk=q)
    assert C[0, 0] == 0 and C[1, 1] == pytest.approx(Q[0, 0])
    emp = th.T @ th / m
    idx = [(1, 1), (5, 5), (39, 39), (10, 30), (20, 39), (3, 38), (25, 26)]
    z = [(emp[i, j] - C[i, j]) / np.sqrt((C[i, i] * C[j, j] + C[i, j] ** 2) / m) for i, j in idx]
    assert np.max(np.abs(z)) < 4.5
    np.testing.assert_allclose(fl.thrice_integrated_covariance(t[:5], t[3:], q_jerk=q), C[:5, 3:])


# --- CSM statistics --------------------------------------------------------------------------------


def test_csm_phase_covariance_estimator():
    kw = dict(n_epochs=400, ts=TS, seed=7, realisations=12, warmup_s=2.0)
    for wrapped in (False, True):
        x = fl.csm_phase_series(0.9, 0.2, wrapped=wrapped, **kw)
        acf = fl.csm_phase_covariance(0.9, 0.2, wrapped=wrapped, n_lags=400, ts=TS, seed=7, realisations=12, warmup_s=2.0)
        assert acf[0] == pytest.approx(np.var(x, axis=1).mean(), rel=1e-10)  # lag 0 = sample variance of the series
        xd = x - x.mean(axis=1, keepdims=True)
        assert acf[37] == pytest.approx(np.mean(np.sum(xd[:, :-37] * xd[:, 37:], axis=1)) / 400, rel=1e-10)
        assert np.linalg.eigvalsh(sl.toeplitz(acf)).min() > -1e-10 * acf[0]  # positive semidefinite
        assert fl.autocovariance(x, demean=False)[0] == pytest.approx(np.mean(x**2), rel=1e-10)
        if wrapped:
            assert np.all(np.abs(x) <= np.pi) and acf[0] <= np.pi**2 / 3
        else:
            assert np.max(np.abs(np.diff(x, axis=1))) <= np.pi
    np.testing.assert_array_equal(fl.csm_phase_series(0.9, 0.2, wrapped=True, **{**kw, "realisations": [3]})[0],
                                  fl.csm_phase_series(0.9, 0.2, wrapped=True, **kw)[3])


def test_wrapped_gaussian_mean_square():
    rng = np.random.default_rng(4)
    for v in (0.005, 0.3, 2.0, 30.0):
        e = np.angle(np.exp(1j * rng.normal(0, np.sqrt(v), 200000)))
        se = (e**2).std() / np.sqrt(e.size)
        assert abs(fl.wrapped_gaussian_ms(v)[0] - (e**2).mean()) < 4 * se
    assert fl.wrapped_gaussian_ms(1e6)[0] == pytest.approx(np.pi**2 / 3)


# --- the table ------------------------------------------------------------------------------------


def tiny_lut() -> xr.Dataset:
    orders = np.arange(1, 4)
    coef = np.zeros((1, 1, 2, 3, 3))
    const = np.zeros((1, 1, 2, 3))
    sigma2 = np.zeros((1, 1, 2, 3))
    for o in orders:
        coef[0, 0, 0, o - 1, 0], const[0, 0, 0, o - 1], sigma2[0, 0, 0, o - 1] = 0.9, 0.1, 1e-3  # amplitude
        coef[0, 0, 1, o - 1, :2], sigma2[0, 0, 1, o - 1] = [1.2, -0.3][:o], 1e-3  # phase
    dims = ("s4", "tau0", "component", "order")
    return xr.Dataset(
        {"coef": (dims + ("lag",), coef), "const": (dims, const), "sigma2": (dims, sigma2)},
        coords={"s4": [0.5], "tau0": [0.4], "component": ["amplitude", "phase"], "order": orders, "lag": orders},
    )


def test_floors_table_layout():
    tracking = dict(cn0_dbhz=CN0, amplitude=1.0, q_jerk_hz2_s3=0.01, p0_diag=[0.25, 1.0, 1e4], theta_s_p0=0.01, rho_p0=0.05,
                    steady_state_start_s=2.0)
    ds = fl.floors_table(tiny_lut(), [(0.5, 0.4)], tracking=tracking, seed=5, duration_s=4.0, realisations=6, groups=3, warmup_s=2.0,
                         stride=5)
    assert ds["rmse"].dims == ("scenario", "reading", "floor")
    assert list(ds["floor"].values) == list(fl.FLOORS) and list(ds["reading"].values) == ["R1", "R2"]
    r = ds["rmse"].sel(scenario="s4_0.5_tau0_0.4")
    assert np.all(np.isfinite(r.values)) and np.all(r.values > 0)
    # the same LUT set in R1 as riccati_floor gives directly
    ar = ScintillationAR.from_coefs([1.2, -0.3], [0.9, 0, 0], 0.1, 1e-3, 1e-3)
    direct = fl.riccati_floor(ar, cn0_dbhz=CN0, ts=TS, q_jerk=0.01, p0_diag=[0.25, 1.0, 1e4], theta_s_p0=0.01, rho_p0=0.05,
                              duration_s=4.0, steady_start_s=2.0)
    assert float(r.sel(reading="R1", floor="riccati_time_varying")) == pytest.approx(direct["time_varying"])
    assert np.isnan(ds["ci_low"].sel(reading="R1", floor="riccati_time_varying")).all()
    lo, hi = ds["ci_low"].sel(floor="gls_with_qd"), ds["ci_high"].sel(floor="gls_with_qd")
    assert np.all((lo <= ds["rmse"].sel(floor="gls_with_qd")) & (ds["rmse"].sel(floor="gls_with_qd") <= hi))
    assert np.all(ds["wrapped_rmse"] <= ds["rmse"] + 1e-12)
    gls = ["gls_quadratic", "gls_with_qd"]
    assert np.all(ds["rmse_offset_corrected"].sel(floor=gls) >= ds["rmse"].sel(floor=gls))
    assert np.isnan(ds["rmse_offset_corrected"].sel(floor="riccati_time_varying")).all()


def test_solve_toeplitz_columns_are_scipys_bit_for_bit():
    """The one-pass Levinson solve of floor (b) gives scipy.linalg.solve_toeplitz's columns as uint64."""
    from scintrack.experiments.toeplitz import solve_toeplitz

    rng = np.random.default_rng(4)
    for n in (1, 2, 3, 50, 600):
        lag = np.arange(n)
        cols = [np.exp(-lag / 40.0) * np.cos(lag / 9.0) + (lag == 0) * 0.3,  # a CSM-like phase covariance plus noise
                np.exp(-lag / 3.0) + (lag == 0) * 1e-3]
        cols.append(0.999**lag + (lag == 0) * 1e-4)  # nearly a unit root: ill-conditioned, as the severe cells' phase
        cols.append(fl.autocovariance(np.cumsum(rng.normal(size=4 * n + 8)))[:n] + (lag == 0) * 0.01)  # a sample one
        for c in cols:
            b = rng.normal(size=(n, 3)) * np.array([1.0, 1e3, 1e-3])
            got = solve_toeplitz(c, b)
            want = sl.solve_toeplitz(c, b, check_finite=False)
            assert np.array_equal(got.view(np.uint64), want.view(np.uint64)), n
            one = sl.solve_toeplitz(c, b[:, 1], check_finite=False)  # one column through scipy: the same bits again
            assert np.array_equal(got[:, 1].view(np.uint64), one.view(np.uint64))
    with pytest.raises(np.linalg.LinAlgError):
        solve_toeplitz(np.array([1.0, 1.0, 1.0]), np.ones((3, 3)))  # singular leading minor of order 2
    b2 = rng.normal(size=(50, 2))  # another width: scipy's own solve
    c50 = np.exp(-np.arange(50) / 5.0)
    assert np.array_equal(solve_toeplitz(c50, b2), sl.solve_toeplitz(c50, b2, check_finite=False))
