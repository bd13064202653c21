"""Achievability floors for the steady-state theta_d error (Vila-Valls 2018, Table III).

The question: can any tracker reach the paper's 0.07-0.12 rad steady-state
theta_d RMSE on CSM scintillation at C/N0 = 30 dB-Hz, Ts = 10 ms (60-s runs,
steady state from 20 s)?  Three lower bounds, each under stated assumptions.
All of them give the error *variance* at each epoch; the floor is the root of
its mean over the steady-state window ``steady_start_s <= t < duration_s``.

(a) :func:`riccati_floor`: Riccati bound of the AEKF-AR's own model.
    State ``x = [theta_d, f_d, f_r, theta_s,k..theta_s,k-p+1, rho_s,k..rho_s,k-q+1]``
    (eq. 11), ``F = blkdiag(F_d, companion(beta), companion(gamma))``,
    ``Q = blkdiag(Q_d(q), sigma2_theta e1 e1^T, sigma2_rho e1 e1^T)`` (eqs. 8-10,
    :mod:`scintrack.trackers.aekf_ar`).  Measurement (eq. 13)
    ``z = A rho [cos(theta_d + theta_s), sin(theta_d + theta_s)] + n``, linearised
    (eq. 14) at ``theta_d + theta_s = 0`` and ``rho = `` the AR amplitude mean
    ``kappa / (1 - sum gamma)``: ``H = [[0 .. A (on rho_s,k)], [A rho (on theta_d), 0, 0,
    A rho (on theta_s,k), 0 ..]]``, ``R = s2/2 I_2``, ``s2 = A^2 / (C/N0 Ts)``.
    The amplitude constant kappa is a known input: it moves the mean, not P.
    At this linearisation point the I row sees only rho and the Q row only
    theta_d + theta_s, and F, Q, P0 are block diagonal, so P+[0,0] does not
    depend on the amplitude AR except through rho; zero-padded lags (the
    tracker's p = q = 3 state) do not change it either.
    ``steady_state``: ``sqrt(P+[0,0])`` of the DARE (``scipy.linalg.solve_discrete_are``);
    ``time_varying``: the Riccati recursion from the tracker's P0 (predict, then
    update; epoch 0 update only, as the AEKF-AR), RMS over the window.  It is
    the exact MSE of the Kalman filter on the *linear Gaussian* model; the EKF
    on the nonlinear model is not bounded by it in a strict sense (it is the
    linearised, known-amplitude, known-noise idealisation).  theta_d and
    theta_s enter only as their sum; with a unit-root AR phase model (severe
    S4, beta_1 ~ 1) theta_d is observable only through the difference in
    dynamics, the DARE is (nearly) undetectable and its steady state is an
    infinite-time limit (``settling_time_s``), so ``time_varying`` is what a
    60-s run can reach.

(b) :func:`gls_floor` with ``q_jerk = 0``: estimator-independent floor in the
    CSM world.  theta_d = a0 + a1 t + a2 t^2 exactly (unknown coefficients, no
    process noise); the receiver observes the total phase
    ``y = theta_d + theta_s + w`` (more than the I/Q prompts give: no 2 pi
    ambiguity, no amplitude-dependent noise), ``w`` white with
    ``R_phi = 1/(2 C/N0 Ts)`` (the thermal phase noise at the nominal amplitude;
    E[1/rho^2] >= 1/E[rho^2] = 1 for the CSM, so this is optimistic), theta_s
    zero-mean Gaussian with the CSM's Toeplitz autocovariance ``C_s``
    (:func:`csm_phase_covariance`).  The best linear unbiased estimator is GLS
    with ``C = C_s + R_phi I``; its theta_d error variance at epoch k is
    ``g_k^T (X^T C^-1 X)^-1 g_k``, ``g_k = [1, t_k, t_k^2]``, using the whole
    60-s window (a smoother).  Any causal filter sees less and can only do
    worse; so does any estimator with a process-noise model.  *Smoother floor*:
    estimating theta_s jointly (its BLUP ``C_s C^-1 (y - X a_hat)``, equivalently
    the fixed-interval Kalman smoother on the joint state with a diffuse prior
    on the polynomial) leaves theta_d's estimate ``X a_hat`` and its error
    covariance unchanged: the BLUE of fixed effects is the posterior mean under a
    flat prior, so the smoother floor *is* this GLS quantity
    (``tests/test_floors.py`` checks it against an RTS smoother).

(c) :func:`gls_floor` with ``q_jerk > 0``: as (b), with theta_d = polynomial +
    a zero-mean Gaussian process ``d`` whose covariance is that of the
    thrice-integrated white jerk of the trackers' Q_d started at t = 0
    (:func:`thrice_integrated_covariance`, closed form; equal to the discrete
    model ``x_{k+1} = F_d x_k + w_k, w_k ~ N(0, Q_d)`` sampled at ``t_k = k Ts``).
    Universal kriging (BLUP with the polynomial as fixed effects,
    ``C = C_s + C_d + R_phi I``):
    ``var_k = C_d[k,k] - c_k^T C^-1 c_k + u_k^T (X^T C^-1 X)^-1 u_k``,
    ``c_k = C_d[:, k]``, ``u_k = g_k - X^T C^-1 c_k``.  This equals the RTS
    smoother of the joint model from a diffuse initial state (checked in the
    tests).  Evaluated on every ``stride``-th epoch of the window (default 10;
    var_k is smooth in k) from the full N x N model (no decimation).

    How (c) is computed (:func:`_differenced_kriging_variance`).  With
    a flat prior on the polynomial, theta_d = X a + d has the improper prior
    ``exp(-1/2 (D3 theta)^T S3^-1 (D3 theta))``: the third difference ``D3``
    annihilates the quadratic, and ``D3 d`` is *exactly* stationary, an MA(2)
    whose autocovariance ``S3`` follows from the closed form (row i of ``D3 d``
    depends on the jerk over [t_i, t_i+3] only).  Kriging = the posterior of
    theta under that prior and ``y = theta + e``, ``e ~ N(0, N)``,
    ``N = C_s + R_phi I``; Woodbury on the posterior precision
    ``D3^T S3^-1 D3 + N^-1`` gives
    ``var_k = N[k,k] - v_k^T G^-1 v_k``, ``v_k = D3 N e_k``, ``G = S3 + D3 N D3^T``,
    and G is (N-3) x (N-3) *Toeplitz*.  G and the v_k are formed in the
    frequency domain from the spectrum of C_s (the time-domain third differences
    of a smooth C_s lose up to 1e-3 relative), ``G^-1`` is applied through the
    Gohberg-Semencul formula (one Levinson solve, ``scipy.linalg.solve_toeplitz``,
    then FFT products): O(N^2) instead of the dense O(N^3/3) Cholesky.
    Precision: G's condition number is ~1e11 at the configured q_jerk = 0.01
    (its low-frequency modes are the jerk's, ~4e-11 against ~1 for the
    differenced thermal noise), so the result carries ~cond * eps of relative
    error: measured at most 3e-5 per epoch variance against an 80-bit dense
    reference (N = 1000, 2000, CSM phase at S4 = 0.9) and 3e-6 against the dense
    float64 solve at N = 6000, where the floors' Monte Carlo intervals are
    percent-wide.  The dense Cholesky (:func:`_dense_kriging_variance`,
    1e-9 or better) is used when the estimated condition number of G exceeds
    ``DIFFERENCED_MAX_COND`` = 1e12 (a small q_jerk), or on request (``method``).

Caveats common to (b) and (c): they are bounds among *linear* estimators (or
exact for a Gaussian theta_s with the same second-order statistics).  The CSM
phase is not Gaussian: its jumps happen in deep amplitude fades, which the
amplitude reveals, and a nonlinear estimator using that coupling is not bounded
by them.  Readings of theta_s: ``R1`` the unwrapped CSM phase (as the scenarios
and the AR look-up table use it), ``R2`` the wrapped ``angle(z)`` (bounded; the
relevant one for a wrapped error metric, since the prompts only carry the phase
modulo 2 pi).

Estimator of C_s (:func:`autocovariance`): each realisation (one 60-s series,
the length of a run) is demeaned, its biased sample autocovariance
``(1/N) sum_t x_t x_{t+l}`` is computed via the zero-padded periodogram, and
the sequences are averaged over realisations.  Each biased sequence is the
autocovariance of a finite sequence, so the Toeplitz matrix is positive
semidefinite by construction; ``C_s + R_phi I`` is positive definite and its
Cholesky factorisation is the check.  Demeaning drops the variance of the
per-run mean of theta_s (the estimate is biased by about ``-Var(mean)`` at every
lag).  A constant lies in the span of X, so it is indistinguishable from a0 and
adds in full to the error of every estimator that is unbiased for the
polynomial: with ``C -> C + s2 1 1^T``, ``(X^T C^-1 X)^-1 -> (X^T C^-1 X)^-1 + s2 e0 e0^T``
and the kriging variance gains exactly ``s2``.  :func:`floors_table` therefore
reports ``window_mean_var`` (the mean over realisations of the squared per-run
mean; the CSM phase has ensemble mean 0 by symmetry) and
``rmse_offset_corrected = sqrt(rmse^2 + window_mean_var)`` for (b) and (c); this
agrees within ~2% with the floors computed from the autocovariance about the
ensemble mean 0 (``autocovariance(..., demean=False)``).  The demeaned floors are
the optimistic ones.  In R1 the unwrapped
phase is not stationary (cycle jumps accumulate), so the Toeplitz C_s is its
stationary surrogate over a 60-s window.

:func:`floors_table` evaluates everything for a list of (S4, tau0) cells.
Monte Carlo intervals (floors (b), (c), and (a) in R2): the realisations are
split into ``groups`` disjoint groups, every floor is recomputed per group, and
the 95% interval is the all-realisation floor +- t_{0.975, G-1} SD(group
floors) / sqrt(G).  Floor (a) in R1 is deterministic given the look-up table
(no interval); in R2 it uses AR(p) phase models fitted (:func:`fit_wrapped_phase_ar`,
statsmodels AutoReg per realisation, realisation-mean coefficients as in the
look-up table, orders of Table I) on the wrapped CSM phase of the same
realisations, with the look-up table's amplitude AR(3).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..models.ar import ArModel, ScintillationAR, fit_ar
from ..models.lut import TABLE_I_PHASE_ORDER, scintillation_ar
from ..models.regions import region_of
from ..progress import Progress
from ..settings import FLOORS_KEYS, TrackingSettings
from ..signals.correlator import noise_power
from ..signals.csm import wrapped_phase
from ..trackers.base import companion, dynamics_F, dynamics_Q

READINGS = ("R1", "R2")
FLOORS = ("riccati_steady", "riccati_time_varying", "gls_quadratic", "gls_with_qd")
T975 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262, 10: 2.228}


# --- (a) Riccati bound of the AEKF-AR model -------------------------------------------------


def riccati_model(ar: ScintillationAR, *, cn0_dbhz: float, ts: float, q_jerk: float, amplitude: float = 1.0,
                  rho: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[int, int]]:
    """``(F, Q, H, R, (p, q))`` of the AEKF-AR model linearised at theta = 0, rho = ``rho`` (default: AR mean)."""
    p, q = max(ar.phase.order, 1), max(ar.amplitude.order, 1)
    n = 3 + p + q
    F, Q = np.zeros((n, n)), np.zeros((n, n))
    F[:3, :3], Q[:3, :3] = dynamics_F(ts), dynamics_Q(q_jerk, ts)
    F[3:3 + p, 3:3 + p] = companion(ar.phase.coefs, p)
    F[3 + p:, 3 + p:] = companion(ar.amplitude.coefs, q)
    Q[3, 3], Q[3 + p, 3 + p] = ar.phase.sigma2, ar.amplitude.sigma2
    rho = ar.rho_mean if rho is None else float(rho)
    H = np.zeros((2, n))
    H[0, 3 + p] = amplitude            # d/d rho of A rho cos(theta) at theta = 0
    H[1, 0] = H[1, 3] = amplitude * rho  # d/d theta of A rho sin(theta) at theta = 0
    R = 0.5 * noise_power(cn0_dbhz, ts, amplitude) * np.eye(2)
    return F, Q, H, R, (p, q)


def _block_eigenvalues(F: np.ndarray, p: int, q: int) -> np.ndarray:
    """Eigenvalues of the block-diagonal F: 1 (dynamics) and the AR roots (exact, from the polynomials)."""
    def roots(coefs):
        return np.roots(np.concatenate([[1.0], -np.asarray(coefs)])) if np.any(coefs) else np.zeros(len(coefs))
    return np.concatenate([[1.0], roots(F[3, 3:3 + p]), roots(F[3 + p, 3 + p:])])


def detectability_margin(F: np.ndarray, H: np.ndarray, eigenvalues: np.ndarray) -> float:
    """Smallest normalised PBH singular value ``sigma_min([lambda I - F; H]) / ||[F; H]||`` over |lambda| >= 1.

    0 means (F, H) is not detectable (an unstable or marginal mode is invisible); inf if no such mode.
    """
    scale = np.linalg.norm(np.vstack([F, H]), 2)
    margins = []
    for lam in np.unique(np.round(eigenvalues[np.abs(eigenvalues) >= 1.0], 14)):
        M = np.vstack([lam * np.eye(F.shape[0]) - F, H.astype(complex)])
        margins.append(np.linalg.svd(M, compute_uv=False)[-1] / scale)
    return float(min(margins)) if margins else float("inf")


def _update(P: np.ndarray, H: np.ndarray, R: np.ndarray) -> np.ndarray:
    S = H @ P @ H.T + R
    K = np.linalg.solve(S, H @ P).T
    Pp = P - K @ S @ K.T
    return 0.5 * (Pp + Pp.T)


def riccati_floor(ar: ScintillationAR, *, cn0_dbhz: float, ts: float, q_jerk: float, amplitude: float = 1.0,
                  rho: float | None = None, p0_diag: Sequence[float], theta_s_p0: float, rho_p0: float,
                  duration_s: float = 60.0, steady_start_s: float = 20.0) -> dict[str, Any]:
    """Floor (a): the AEKF-AR model's own Riccati bound on theta_d (module docstring).

    Returns a dict: ``steady_state`` (sqrt P+[0,0] of the DARE [rad], NaN if
    the DARE has no valid solution), ``steady_state_reason`` ("" or why NaN /
    why it is irrelevant), ``settling_time_s`` (time constant of the slowest
    closed-loop mode of the DARE gain), ``detectability_margin``,
    ``time_varying`` (RMS over the window of sqrt P+[0,0] from P0 [rad]),
    ``time`` [s] and ``p_theta_d`` [rad^2] (P+[0,0] per epoch), ``phase_noise_var``
    (R / (A rho)^2 [rad^2], the equivalent phase-measurement noise) and ``rho``.
    """
    F, Q, H, R, (p, q) = riccati_model(ar, cn0_dbhz=cn0_dbhz, ts=ts, q_jerk=q_jerk, amplitude=amplitude, rho=rho)
    n = F.shape[0]
    rho_lin = float(H[1, 0] / amplitude)
    out: dict[str, Any] = {"rho": rho_lin, "phase_noise_var": float(R[1, 1] / H[1, 0] ** 2)}
    eig = _block_eigenvalues(F, p, q)
    margin = detectability_margin(F, H, eig)
    out["detectability_margin"] = margin
    out["steady_state"], out["settling_time_s"], reasons = float("nan"), float("nan"), []
    if margin < 1e-10:
        reasons.append(f"(F, H) not detectable to working precision (PBH margin {margin:.1e}): theta_d and theta_s enter only as their sum")
    else:
        from scipy.linalg import solve_discrete_are

        try:
            P = solve_discrete_are(F.T, H.T, Q, R)
        except (np.linalg.LinAlgError, ValueError) as exc:
            reasons.append(f"DARE solver failed: {exc}")
            P = None
        if P is not None:
            S = H @ P @ H.T + R
            resid = F @ P @ F.T - F @ P @ H.T @ np.linalg.solve(S, H @ P @ F.T) + Q - P
            rel = float(np.linalg.norm(resid) / max(np.linalg.norm(P), 1e-300))
            Pp = _update(P, H, R)
            min_eig = float(np.linalg.eigvalsh(0.5 * (P + P.T)).min())
            if not np.all(np.isfinite(P)) or rel > 1e-6 or min_eig < -1e-8 * np.abs(P).max() or Pp[0, 0] <= 0:
                reasons.append(f"DARE solution invalid (relative residual {rel:.1e}, min eigenvalue {min_eig:.2e}, P+[0,0] {Pp[0, 0]:.2e})")
            else:
                out["steady_state"] = float(np.sqrt(Pp[0, 0]))
                K = P @ H.T @ np.linalg.inv(S)
                r = float(np.abs(np.linalg.eigvals(F @ (np.eye(n) - K @ H))).max())
                out["settling_time_s"] = float(-ts / np.log(r)) if r < 1 else float("inf")
                if out["settling_time_s"] > duration_s:
                    reasons.append(f"steady state reached only after ~{out['settling_time_s']:.3g} s (slowest closed-loop mode), "
                                   f"longer than a {duration_s:g}-s run")
    root = float(np.abs(eig[1:1 + p]).max())
    if root >= 1.0 - 1e-3:
        reasons.append(f"phase AR root |z| = {root:.6f} (unit root: theta_d weakly observable)")
    out["steady_state_reason"] = "; ".join(reasons)
    # time-varying Riccati from the tracker's P0 (epoch 0: update only)
    n_ep = int(round(duration_s / ts))
    P = np.diag(np.concatenate([np.asarray(p0_diag, dtype=float), np.full(p, float(theta_s_p0)), np.full(q, float(rho_p0))]))
    p00 = np.empty(n_ep)
    for k in range(n_ep):
        if k > 0:
            P = F @ P @ F.T + Q
        P = _update(P, H, R)
        p00[k] = P[0, 0]
    time = np.arange(n_ep) * ts
    window = time >= steady_start_s - 1e-9
    out.update(time=time, p_theta_d=p00, time_varying=float(np.sqrt(p00[window].mean())))
    return out


# --- CSM phase statistics -------------------------------------------------------------------


def _csm_name(s4: float, tau0: float) -> str:
    return f"floors/csm/s4-{s4:g}/tau0-{tau0:g}"


def csm_phase_series(s4: float, tau0: float, *, wrapped: bool, n_epochs: int, ts: float, seed: int,
                     realisations: int | Sequence[int], nspa: int = 8, warmup_s: float = 10.0,
                     batch: int = 25) -> np.ndarray:
    """CSM scintillation phase, shape (realisations, n_epochs): ``angle(z)`` (wrapped) or its unwrap along time.

    ``generate_csm`` (integrate-and-dump output, ``warmup_s`` of warm-up dropped)
    with one stream per realisation (name ``floors/csm/s4-../tau0-..``), in batches.
    """
    from ..signals.csm import generate_csm

    trials = list(range(realisations)) if isinstance(realisations, (int, np.integer)) else list(realisations)
    warmup = int(round(warmup_s / ts))
    out = np.empty((len(trials), n_epochs))
    for i in range(0, len(trials), batch):
        z = generate_csm(seed=seed, name=_csm_name(s4, tau0), trials=trials[i:i + batch], n_epochs=n_epochs, ts=ts,
                         s4=s4, tau0=tau0, nspa=nspa, warmup=warmup).z
        ph = np.angle(z)
        out[i:i + batch] = ph if wrapped else np.unwrap(ph, axis=-1)
    return out


def autocovariance(series: np.ndarray, demean: bool = True) -> np.ndarray:
    """Average over rows of the biased sample autocovariance of each demeaned row, lags 0..N-1.

    ``c_l = mean_r (1/N) sum_t (x_rt - xbar_r)(x_r,t+l - xbar_r)``, via the
    periodogram zero-padded to >= 2N (no circular wrap); positive semidefinite.
    ``demean=False``: about a known mean 0 instead of each row's mean.
    """
    x = np.atleast_2d(np.asarray(series, dtype=float))
    n = x.shape[1]
    if demean:
        x = x - x.mean(axis=1, keepdims=True)
    nfft = 1 << int(np.ceil(np.log2(2 * n)))
    spec = np.abs(np.fft.rfft(x, nfft, axis=1)) ** 2
    return np.fft.irfft(spec.mean(axis=0), nfft)[:n] / n


def csm_phase_covariance(s4: float, tau0: float, *, wrapped: bool, n_lags: int, ts: float, seed: int,
                         realisations: int | Sequence[int], nspa: int = 8, warmup_s: float = 10.0, demean: bool = True) -> np.ndarray:
    """Autocovariance [rad^2] of the CSM phase at lags 0..n_lags-1 (:func:`autocovariance` of
    :func:`csm_phase_series` with ``n_epochs = n_lags``: one series of the run's length per realisation)."""
    x = csm_phase_series(s4, tau0, wrapped=wrapped, n_epochs=n_lags, ts=ts, seed=seed, realisations=realisations, nspa=nspa,
                         warmup_s=warmup_s)
    return autocovariance(x, demean=demean)


def fit_wrapped_phase_ar(series: np.ndarray, s4: float, amplitude: ArModel, tau0: float = float("nan"),
                         order: int | None = None) -> ScintillationAR:
    """AR(p) phase model (no constant, Table I order unless given) fitted on each row of ``series``,
    realisation-mean coefficients and driving variance, paired with ``amplitude``."""
    p = order or TABLE_I_PHASE_ORDER[region_of(s4)]
    fits = [fit_ar(row, p, "n") for row in np.atleast_2d(series)]
    phase = ArModel(coefs=np.mean([f.coefs for f in fits], axis=0), const=0.0, sigma2=float(np.mean([f.sigma2 for f in fits])))
    return ScintillationAR(phase=phase, amplitude=amplitude, s4=s4, tau0=tau0, label=f"wrapped-phase fit S4={s4:g},tau0={tau0:g},AR({p})")


# --- (b), (c): GLS / universal-kriging floors -------------------------------------------------


def thrice_integrated_covariance(t1: np.ndarray, t2: np.ndarray | None = None, *, q_jerk: float) -> np.ndarray:
    """Covariance [rad^2] of theta(t) = 2 pi int_0^t f_d, f_d = double integral of a white jerk (PSD ``q_jerk``), from rest at t = 0.

    ``theta(t) = 2 pi int_0^t (t - v)^2 / 2 j(v) dv``, so with ``m = min(s, t)``, ``D = |s - t|``:
    ``Cov(theta(s), theta(t)) = (2 pi)^2 q / 4 (m^5/5 + D m^4/2 + D^2 m^3/3)``
    (``(2 pi)^2 q t^5 / 20`` on the diagonal, Q_d[0, 0] at t = Ts).
    """
    t1 = np.asarray(t1, dtype=float)
    t2 = t1 if t2 is None else np.asarray(t2, dtype=float)
    m = np.minimum.outer(t1, t2)
    d = np.abs(np.subtract.outer(t1, t2))
    m3 = m**3
    return (2 * np.pi) ** 2 * q_jerk / 4.0 * m3 * (m * m / 5.0 + d * m / 2.0 + d * d / 3.0)


#: Third difference: ``(D3 x)_i = sum_a D3[a] x_(i+a)``; it annihilates a quadratic in i.
D3 = np.array([-1.0, 3.0, -3.0, 1.0])
#: Autocorrelation of D3 at lags 0..3 ([20, -15, 6, -1]): ``D3 (R I) D3^T`` of white noise of variance R is R times it.
D3_ACF = np.correlate(D3, D3, "full")[D3.size - 1:]
#: Largest estimated condition number of G for which floor (c) uses the differenced O(N^2) route (module docstring).
DIFFERENCED_MAX_COND = 1e12


def _differenced_dynamics_acf(ts: float, q_jerk: float) -> np.ndarray:
    """Autocovariance of ``D3 d`` (d: :func:`thrice_integrated_covariance` at ``t_k = k ts``) at lags 0..3 (lag 3 is 0: MA(2))."""
    t = np.arange(7) * ts
    M = np.zeros((4, 7))
    for i in range(4):
        M[i, i:i + 4] = D3
    return (M @ thrice_integrated_covariance(t, q_jerk=q_jerk) @ M.T)[0]


@functools.lru_cache(maxsize=1)
def _dynamics_covariance(n: int, ts: float, q_jerk: float) -> np.ndarray:
    """C_d of :func:`thrice_integrated_covariance` at ``t_k = k ts``, k < n (read-only; the same for every dense (c) solve of a job)."""
    t = np.arange(n) * ts
    cd = np.empty((n, n))
    for r in range(0, n, 500):  # row blocks: no further N x N temporaries
        cd[r:r + 500] = thrice_integrated_covariance(t[r:r + 500], t, q_jerk=q_jerk)
    cd.setflags(write=False)
    return cd


def _dense_kriging_variance(cov_s: np.ndarray, k: np.ndarray, X: np.ndarray, *, n: int, ts: float, r_phi: float,
                            q_jerk: float) -> np.ndarray:
    """Floor (c) at epochs ``k`` from the dense Cholesky of ``C = C_s + C_d + R_phi I`` (module docstring)."""
    from scipy.linalg import cho_factor, cho_solve, toeplitz

    t = np.arange(n) * ts
    C = toeplitz(cov_s[:n])
    C[np.diag_indices(n)] += r_phi
    C += _dynamics_covariance(n, ts, q_jerk)
    try:
        cf = cho_factor(C, lower=True, overwrite_a=True, check_finite=False)
    except np.linalg.LinAlgError as exc:
        raise np.linalg.LinAlgError("C = C_s + C_d + R_phi I is not positive definite") from exc
    V = np.linalg.inv(X.T @ cho_solve(cf, X, check_finite=False))
    cd = thrice_integrated_covariance(t, t[k], q_jerk=q_jerk)
    ci_cd = cho_solve(cf, cd, check_finite=False)
    u = X[k].T - X.T @ ci_cd
    return cd[k, np.arange(k.size)] - np.sum(cd * ci_cd, axis=0) + np.einsum("ik,ij,jk->k", u, V, u)


def _differenced_kriging_variance(cov_s: np.ndarray, k: np.ndarray, *, n: int, ts: float, r_phi: float,
                                  q_jerk: float) -> np.ndarray | None:
    """Floor (c) at epochs ``k`` as ``N[k,k] - v_k^T G^-1 v_k`` with Toeplitz G (module docstring); None if G's
    estimated condition number exceeds ``DIFFERENCED_MAX_COND``."""
    from scipy.linalg import solve_toeplitz

    m = n - 3
    c = np.asarray(cov_s[:n], dtype=float)
    nfft = 1 << int(np.ceil(np.log2(2 * n + 8)))
    circ = np.zeros(nfft)
    circ[:n], circ[nfft - n + 1:] = c, c[:0:-1]  # C_s as a symmetric circular sequence (lags -(n-1)..n-1)
    spec = np.fft.rfft(circ).real
    dh = np.fft.rfft(D3, nfft)
    d2 = np.abs(dh) ** 2
    s3 = _differenced_dynamics_acf(ts, q_jerk)
    # spectrum of G on the FFT grid (C_s, white R_phi, MA(2) S3): the condition estimate (C_s's spectrum clipped at 0:
    # a truncated autocovariance that is not a biased sample estimate can dip below, where its Toeplitz section need not)
    w = np.linspace(0.0, np.pi, spec.size)  # the rfft grid
    spec_g = (np.maximum(spec, 0.0) + r_phi) * d2 + s3[0] + 2 * s3[1] * np.cos(w) + 2 * s3[2] * np.cos(2 * w)
    if spec_g.min() <= 0 or spec_g.max() / spec_g.min() > DIFFERENCED_MAX_COND:
        return None
    g = np.fft.irfft(spec * d2, nfft)[:m]  # D3 C_s D3^T: lags 0..m-1
    g[:4] += r_phi * D3_ACF + s3
    h = np.fft.irfft(spec * np.conj(dh), nfft)  # h_j = sum_a D3[a] C_s(j + a), j mod nfft
    h[(-np.arange(4)) % nfft] += r_phi * D3  # and of R_phi I
    # V[:, j] = D3 N e_(k_j), held as V^T (one row per epoch k_j) so that every FFT runs along contiguous rows:
    # numpy's FFT gives each 1-D transform the same bits along either axis, and along rows it is ~40% faster
    vt = h[(np.arange(m)[None, :] - k[:, None]) % nfft]
    # Gohberg-Semencul: G^-1 = (L(x) L(x)^T - L(Z J x) L(Z J x)^T) / x_0, x = G^-1 e_0, L(v): lower-triangular Toeplitz
    x = solve_toeplitz(g, np.eye(m, 1)[:, 0], check_finite=False)
    zjx = np.concatenate([[0.0], x[:0:-1]])
    fvt = np.fft.rfft(vt, nfft, axis=-1)
    qf = np.zeros(k.size)
    for sign, col in ((1.0, x), (-1.0, zjx)):  # (L(col)^T V)_i = sum_s col_s V_(i+s): a correlation
        lt_vt = np.fft.irfft(np.conj(np.fft.rfft(col, nfft))[None, :] * fvt, nfft, axis=-1)[:, :m]
        lt_v = np.ascontiguousarray(lt_vt.T)  # (m, epochs) as before, so the sum over i keeps einsum's order and bits
        qf += sign * np.einsum("ij,ij->j", lt_v, lt_v)
    return c[0] + r_phi - qf / x[0]


def phase_noise_variance(cn0_dbhz: float, ts: float) -> float:
    """``R_phi = 1 / (2 C/N0 Ts)`` [rad^2]: thermal phase noise of one prompt at the nominal amplitude."""
    return 1.0 / (2.0 * 10.0 ** (cn0_dbhz / 10.0) * ts)


def gls_error_variance(cov_s: np.ndarray, *, ts: float, cn0_dbhz: float, duration_s: float = 60.0, steady_start_s: float = 20.0,
                       q_jerk: float = 0.0, stride: int | None = None, method: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """theta_d error variance [rad^2] of floor (b) (``q_jerk = 0``) or (c) at the window epochs; returns ``(t, var)``.

    ``cov_s``: autocovariance of theta_s at lags 0..N-1 (N = duration/ts; zeros
    for no scintillation).  ``stride``: evaluate every ``stride``-th epoch of the
    window (default 1 for (b), 10 for (c)).  ``method`` (floor (c) only):
    ``"auto"`` (differenced O(N^2) route unless G is too ill-conditioned),
    ``"differenced"`` (that route or an error) or ``"dense"`` (Cholesky); see the module docstring.
    """
    from .toeplitz import solve_toeplitz  # scipy.linalg.solve_toeplitz's values, its columns in one Levinson pass

    n = int(round(duration_s / ts))
    cov_s = np.asarray(cov_s, dtype=float)
    if cov_s.size < n:
        raise ValueError(f"cov_s has {cov_s.size} lags, the window needs {n}")
    stride = stride or (1 if q_jerk == 0 else 10)
    t = np.arange(n) * ts
    k = np.arange(int(round(steady_start_s / ts)), n, stride)
    X = np.vander(t / duration_s, 3, increasing=True)  # scaled basis: same span, better conditioned
    if q_jerk == 0:  # C = C_s + R_phi I is Toeplitz: Levinson, O(n^2), the 3 columns of X in one pass
        col = cov_s[:n].copy()
        col[0] += phase_noise_variance(cn0_dbhz, ts)
        V = np.linalg.inv(X.T @ solve_toeplitz(col, X))
        var = np.einsum("ki,ij,kj->k", X[k], V, X[k])
    else:
        if method not in ("auto", "differenced", "dense"):
            raise ValueError(f"method must be 'auto', 'differenced' or 'dense', not {method!r}")
        r_phi = phase_noise_variance(cn0_dbhz, ts)
        var = None if method == "dense" else _differenced_kriging_variance(cov_s, k, n=n, ts=ts, r_phi=r_phi, q_jerk=q_jerk)
        if var is None and method == "differenced":
            raise np.linalg.LinAlgError(f"G is too ill-conditioned for the differenced route (> {DIFFERENCED_MAX_COND:g}); use method='dense'")
        if var is None:
            var = _dense_kriging_variance(cov_s, k, X, n=n, ts=ts, r_phi=r_phi, q_jerk=q_jerk)
    if np.any(var <= 0):
        raise FloatingPointError("non-positive error variance: C is too ill-conditioned")
    return t[k], var


def gls_floor(cov_s: np.ndarray, *, ts: float, cn0_dbhz: float, duration_s: float = 60.0, steady_start_s: float = 20.0,
              q_jerk: float = 0.0, stride: int | None = None) -> float:
    """Floor (b) (``q_jerk = 0``) or (c) [rad]: RMS over the window of :func:`gls_error_variance`."""
    _, var = gls_error_variance(cov_s, ts=ts, cn0_dbhz=cn0_dbhz, duration_s=duration_s, steady_start_s=steady_start_s, q_jerk=q_jerk,
                                stride=stride)
    return float(np.sqrt(var.mean()))


def wrapped_gaussian_ms(var: np.ndarray) -> np.ndarray:
    """``E[wrap(e)^2]`` for ``e ~ N(0, var)``, wrap to (-pi, pi]: ``pi^2/3 + 4 sum_n (-1)^n exp(-n^2 var/2) / n^2``.

    For comparing a Gaussian floor with a wrapped RMSE (<= var; -> pi^2/3 for large var).
    """
    v = np.atleast_1d(np.asarray(var, dtype=float))
    out = v.copy()  # var < 0.01: P(|e| > pi) < 1e-200
    big = v >= 0.01
    if np.any(big):
        nmax = int(np.ceil(np.sqrt(80.0 / v[big].min()))) + 1
        nn = np.arange(1, nmax + 1)
        terms = (-1.0) ** nn / nn**2 * np.exp(-np.outer(v[big], nn**2) / 2.0)
        out[big] = np.pi**2 / 3.0 + 4.0 * terms.sum(axis=1)
    return out


# --- the table -----------------------------------------------------------------------------------


def _interval(full: float, groups: Sequence[float]) -> tuple[float, float]:
    g = np.asarray(groups, dtype=float)
    if g.size < 2 or not np.all(np.isfinite(g)):
        return float("nan"), float("nan")
    half = T975.get(g.size - 1, 1.96) * g.std(ddof=1) / np.sqrt(g.size)
    return max(full - half, 0.0), full + half  # an RMSE floor is >= 0


def floors_table(lut, scenarios: Sequence[tuple[float, float]], *, tracking: Mapping[str, Any], seed: int, ts: float = 0.01,
                 duration_s: float = 60.0, realisations: int = 200, groups: int = 5, nspa: int = 8, warmup_s: float = 10.0,
                 stride: int = 10, progress=None) -> Any:
    """All floors for the (S4, tau0) cells: ``xarray.Dataset`` with dims (scenario, reading, floor).

    ``tracking``: the tracking settings of :data:`.settings.FLOORS_KEYS` (``cn0_dbhz``, ``amplitude``,
    ``q_jerk_hz2_s3``, ``p0_diag``, ``theta_s_p0``, ``rho_p0``, ``steady_state_start_s``).  Variables:
    ``rmse`` (the floor [rad]), ``ci_low``/``ci_high`` (95%, group split; NaN where the
    floor is not a Monte Carlo estimate), ``wrapped_rmse`` (RMS of the wrapped
    Gaussian error with the floor's per-epoch variances, the comparator for a
    wrapped RMSE), ``window_mean_var`` (variance of the per-run mean of theta_s,
    left out of C_s), ``rmse_offset_corrected`` (``sqrt(rmse^2 + window_mean_var)``
    for (b) and (c), interval shifted the same way; NaN for (a)),
    ``riccati_note`` and ``riccati_settling_time_s``.
    ``progress``: where to write progress lines (readings done, rate, ETA), e.g. a log's ``info``.
    """
    import xarray as xr

    tr = TrackingSettings.from_params(tracking, require=FLOORS_KEYS)
    cn0, amp, q = tr.cn0_dbhz, tr.amplitude, tr.q_jerk_hz2_s3
    start = tr.steady_state_start_s
    ric_kw = dict(cn0_dbhz=cn0, ts=ts, q_jerk=q, amplitude=amp, p0_diag=tr.p0_diag, theta_s_p0=tr.theta_s_p0,
                  rho_p0=tr.rho_p0, duration_s=duration_s, steady_start_s=start)
    gls_kw = dict(ts=ts, cn0_dbhz=cn0, duration_s=duration_s, steady_start_s=start)
    n = int(round(duration_s / ts))
    shape = (len(scenarios), len(READINGS), len(FLOORS))
    rmse, lo, hi, wr = (np.full(shape, np.nan) for _ in range(4))
    wmv = np.full(shape[:2], np.nan)
    settle = np.full(shape[:2], np.nan)
    notes = np.full(shape[:2], "", dtype=object)
    split = np.array_split(np.arange(realisations), groups)

    def wrapped_rms(var):
        return float(np.sqrt(wrapped_gaussian_ms(var).mean()))

    prog = Progress(len(scenarios) * len(READINGS), unit="readings", log=progress, label=f"floors ({realisations} realisations)")
    for i, (s4, tau0) in enumerate(scenarios):
        ar1 = scintillation_ar(lut, s4, tau0)
        unwrapped = csm_phase_series(s4, tau0, wrapped=False, n_epochs=n, ts=ts, seed=seed, realisations=realisations, nspa=nspa,
                                     warmup_s=warmup_s)
        series = {"R1": unwrapped, "R2": wrapped_phase(unwrapped)}  # R2: as the scenarios make it
        for j, reading in enumerate(READINGS):
            x = series[reading]
            wmv[i, j] = float(np.mean(x.mean(axis=1) ** 2))
            # (a)
            if reading == "R1":
                sets, group_sets = ar1, []
            else:
                sets = fit_wrapped_phase_ar(x, s4, ar1.amplitude, tau0)
                group_sets = [fit_wrapped_phase_ar(x[g], s4, ar1.amplitude, tau0) for g in split]
            ric = riccati_floor(sets, **ric_kw)
            window = ric["time"] >= start - 1e-9
            rmse[i, j, 0], rmse[i, j, 1] = ric["steady_state"], ric["time_varying"]
            wr[i, j, 1] = wrapped_rms(ric["p_theta_d"][window])
            if np.isfinite(ric["steady_state"]):
                wr[i, j, 0] = wrapped_rms(ric["steady_state"] ** 2)
            notes[i, j] = (f"AR set {sets.label}: beta={np.round(sets.phase.coefs, 6).tolist()}, sigma2={sets.phase.sigma2:.3g}. "
                           + (ric["steady_state_reason"] or "DARE valid"))
            settle[i, j] = ric["settling_time_s"]
            if group_sets:
                gr = [riccati_floor(s, **ric_kw) for s in group_sets]
                for f in (0, 1):
                    key = ("steady_state", "time_varying")[f]
                    lo[i, j, f], hi[i, j, f] = _interval(rmse[i, j, f], [g[key] for g in gr])
            # (b), (c)
            acf = autocovariance(x)
            group_acf = [autocovariance(x[g]) for g in split]
            for f, qq in ((2, 0.0), (3, q)):
                _, var = gls_error_variance(acf, q_jerk=qq, stride=None if qq == 0 else stride, **gls_kw)
                rmse[i, j, f], wr[i, j, f] = float(np.sqrt(var.mean())), wrapped_rms(var)
                gvals = [gls_floor(a, q_jerk=qq, stride=None if qq == 0 else stride, **gls_kw) for a in group_acf]
                lo[i, j, f], hi[i, j, f] = _interval(rmse[i, j, f], gvals)
            prog.add(1, note=f"S4 {s4:g} tau0 {tau0:g} {reading}")
    corr, corr_lo, corr_hi = (np.full(shape, np.nan) for _ in range(3))
    gls = [FLOORS.index("gls_quadratic"), FLOORS.index("gls_with_qd")]
    for dst, src in ((corr, rmse), (corr_lo, lo), (corr_hi, hi)):
        dst[:, :, gls] = np.sqrt(src[:, :, gls] ** 2 + wmv[:, :, None])
    labels = [f"s4_{s4:g}_tau0_{tau0:g}" for s4, tau0 in scenarios]
    dims = ("scenario", "reading", "floor")
    ds = xr.Dataset(
        {
            "rmse": (dims, rmse, {"long_name": "theta_d error floor (RMS over the steady-state window)", "units": "rad"}),
            "ci_low": (dims, lo, {"long_name": "lower end of the 95% interval (group split)", "units": "rad"}),
            "ci_high": (dims, hi, {"long_name": "upper end of the 95% interval (group split)", "units": "rad"}),
            "rmse_offset_corrected": (dims, corr, {"long_name": "sqrt(rmse^2 + window_mean_var) for the GLS floors", "units": "rad"}),
            "corrected_ci_low": (dims, corr_lo, {"long_name": "ci_low shifted by window_mean_var", "units": "rad"}),
            "corrected_ci_high": (dims, corr_hi, {"long_name": "ci_high shifted by window_mean_var", "units": "rad"}),
            "wrapped_rmse": (dims, wr, {"long_name": "RMS of the wrapped Gaussian error with the floor's variances", "units": "rad"}),
            "window_mean_var": (dims[:2], wmv, {"long_name": "variance of the per-run mean of theta_s (not in C_s)", "units": "rad2"}),
            "riccati_settling_time_s": (dims[:2], settle, {"long_name": "slowest closed-loop time constant (DARE)", "units": "s"}),
            "riccati_note": (dims[:2], notes.astype(str)),
        },
        coords={"scenario": labels, "reading": list(READINGS), "floor": list(FLOORS),
                "s4": ("scenario", [float(s) for s, _ in scenarios]), "tau0": ("scenario", [float(t) for _, t in scenarios])},
    )
    ds.attrs.update(
        cn0_dbhz=cn0, ts=ts, duration_s=duration_s, steady_state_start_s=start, q_jerk_hz2_s3=q, realisations=realisations, groups=groups,
        seed=seed, nspa=nspa, warmup_s=warmup_s, gls_with_qd_stride=stride,
        description="Achievability floors for theta_d (scintrack.experiments.floors): R1 unwrapped, R2 wrapped CSM phase; "
                    "riccati_* in R1 use the AR look-up table, in R2 AR phase models fitted on the wrapped CSM phase.",
    )
    return ds
