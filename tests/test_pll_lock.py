"""The Costas PLL as a receiver runs it (``zhao_receiver.pll_lock``, :mod:`scintrack.trackers.pll_lock`).

- the FLL discriminator is exact on a noise-free tone, and the FLL gain gives the stated noise bandwidth;
- the on-line lock detector is the same detector as the batch one;
- with a detector that never trips, the loop is the bare PLL bit for bit;
- through a jammed span the frequency stays within +-25 Hz (the bare PLL runs to hundreds of Hz) and the
  loop relocks after the jamming ends;
- in the receiver: without the option nothing changes; with it the other trackers' outputs are the same.
"""

import copy

import numpy as np
import pytest

from scintrack.experiments.lock_detector import lock_state, lock_update, window_epochs
from scintrack.trackers import pll_lock as pl
from scintrack.trackers.base import TrackInit
from scintrack.trackers.pll import PLL

T = 1e-3
CLEAN1, JAM, CLEAN2 = 8.0, 20.0, 8.0  # seconds: clean, jammed (15 dB-Hz), clean again (46 dB-Hz)
F0, RATE = 3.0, 0.1  # residual frequency [Hz] and its rate [Hz/s]
SETTINGS = pl.PllLockSettings(threshold_rad=0.5, window_s=1.0, fll_bandwidth_hz=0.5, fll_integration_ms=10)


def _jammed_prompts(n_trials: int, seed: int = 11):
    """1-ms prompts with unit noise per component, data bits, a frequency ramp and a jammed span."""
    k = int(round((CLEAN1 + JAM + CLEAN2) / T))
    t = np.arange(k) * T
    phi = 2 * np.pi * (F0 * t + 0.5 * RATE * t**2)
    cn0 = np.where((t >= CLEAN1) & (t < CLEAN1 + JAM), 15.0, 46.0)
    amp = np.sqrt(2 * 10 ** (cn0 / 10) * T)
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    bits = np.repeat(rng.choice([-1.0, 1.0], size=k // 20 + 1), 20)[:k]
    y = amp * bits * np.exp(1j * phi) + rng.standard_normal((n_trials, k)) + 1j * rng.standard_normal((n_trials, k))
    init = TrackInit(phase=np.full(n_trials, phi[0]), doppler_hz=np.full(n_trials, F0), rate_hz_s=np.zeros(n_trials))
    return t, phi, F0 + RATE * t, y, init


PLL_10 = PLL(ts=T, bandwidth_hz=10.0, discriminator="atan")


@pytest.mark.parametrize("df", [-47.0, -12.3, 0.0, 0.8, 24.9, 49.0])
def test_fll_discriminator_is_exact_on_a_noise_free_tone(df):
    m = 10
    y = np.exp(2j * np.pi * df * np.arange(2 * m) * T) * np.exp(0.7j)
    a, b = y[:m].sum(), y[m:].sum()
    cross = a.real * b.imag - b.real * a.imag
    dot = a.real * b.real + a.imag * b.imag
    assert pl.fll_discriminator(cross, dot, m * T) == pytest.approx(df, abs=1e-9)


@pytest.mark.parametrize("bandwidth", [0.25, 0.5, 2.0, 8.0])
def test_fll_gain_gives_the_noise_bandwidth(bandwidth):
    """First-order loop x <- x + K (u - x): impulse response K (1 - K)^n, B_n = sum h^2 / (2 T sum h)^... = K / (2 T (2 - K))."""
    tb = 0.02
    k = pl.fll_gain(bandwidth, tb)
    h = k * (1 - k) ** np.arange(200000)
    assert np.sum(h) == pytest.approx(1.0, rel=1e-9)
    assert np.sum(h**2) / (2 * tb) == pytest.approx(bandwidth, rel=1e-9)


def test_online_detector_is_the_batch_detector():
    rng = np.random.default_rng(np.random.SeedSequence(3))
    err = np.concatenate([rng.normal(0, 0.2, 300), rng.uniform(-np.pi / 2, np.pi / 2, 200), rng.normal(0, 0.2, 300)])
    ts, window_s, thr = 0.02, 1.0, 0.5
    batch = lock_state(err, ts, thr, window_s)
    buf = np.empty(window_epochs(ts, window_s))
    count, total, online = 0, 0.0, []
    for x in np.abs(err):
        count, total, ok = lock_update(buf, count, total, x, thr)
        online.append(ok)
    np.testing.assert_array_equal(np.array(online), batch)
    assert batch[:250].all() and not batch[350:500].any() and batch[-1]  # the span is seen as lost, then regained


def test_a_detector_that_never_trips_gives_the_bare_pll_bit_for_bit():
    t, phi, f, y, init = _jammed_prompts(3)
    never = SETTINGS._replace(threshold_rad=10.0)
    out = pl.run(PLL_10, y, init, 7, never)
    ref = PLL_10.run(y, init)
    assert out.extras["locked"].all()
    np.testing.assert_array_equal(out.theta_d, ref.theta_d)
    np.testing.assert_array_equal(out.extras["frequency_hz"], ref.extras["frequency_hz"])


def test_through_jamming_the_frequency_stays_bounded_and_the_loop_relocks():
    t, phi, f, y, init = _jammed_prompts(8)
    jam = (t >= CLEAN1) & (t < CLEAN1 + JAM)
    bare = PLL_10.run(y, init).extras["frequency_hz"] - f
    assert np.all(np.abs(bare[:, jam]).max(axis=1) > 100.0)  # the bare Costas PLL runs away
    out = pl.run(PLL_10, y, init, 0, SETTINGS)
    ferr = out.extras["frequency_hz"] - f
    locked = out.extras["locked"]
    assert np.all(np.abs(ferr) < 25.0)  # held / re-pulled within 1 / (2 x 20 ms) at every epoch
    assert locked[:, t < CLEAN1].all()
    assert locked[:, jam].mean() < 0.1  # the detector sees the loss (15 dB-Hz: no phase lock at 1 ms)
    back = t >= CLEAN1 + JAM + 3.0
    assert locked[:, back].all()  # relocked within 3 s of the end of the jamming
    err = np.angle(np.exp(2j * (out.theta_d - phi))) / 2  # Costas: modulo pi
    assert np.sqrt(np.mean(err[:, back] ** 2)) < 0.05
    assert np.abs(ferr[:, back]).max() < 1.0


def test_frequency_hold_alone_keeps_the_held_frequency():
    t, phi, f, y, init = _jammed_prompts(4)
    out = pl.run(PLL_10, y, init, 0, SETTINGS._replace(fll_bandwidth_hz=0.0))
    freq = out.extras["frequency_hz"]
    jam = (t >= CLEAN1 + 1.5) & (t < CLEAN1 + JAM)  # after the detector's 1-s window has tripped
    held = freq[:, jam]
    assert np.all(held == held[:, :1])  # frozen
    assert np.all(np.abs(held[:, 0] - (F0 + RATE * CLEAN1)) < 1.5)  # at the last in-lock estimate (before the failing window)


def test_bad_fll_integration_names_the_setting():
    with pytest.raises(ValueError, match=r"zhao_receiver\.pll_lock\.fll_integration_ms = 3"):
        pl.settings({"fll_bandwidth_hz": 0.5, "fll_integration_ms": 3}, {"threshold_rad": 0.5, "window_s": 1.0})


@pytest.fixture(scope="module")
def receiver_runs():
    from test_gps_dataset import small_config

    from scintrack.data.gps_jamming_build import build
    from scintrack.data.gps_jamming_spec import gps_jamming_params
    from scintrack.experiments.gps_receiver import channel, prior_sources
    from scintrack.pipeline import params as P
    from scintrack.project import project_file
    from scintrack.signals.gps import ephemeris

    rinex = project_file("data/ephemerides/brdc2800.15n")
    cfg = small_config(duration_s=12.0, message_lead_s=30.0, uploads=[])
    cfg["gps_jamming"]["jammer"] = {**cfg["gps_jamming"]["jammer"], "onset_s": 6.0}
    cfg["zhao_receiver"].update(trials=2, variants=["mm_none"])
    ds = build(gps_jamming_params(cfg), rinex)
    ephs, header = ephemeris.load(rinex), ephemeris.read_header(rinex)
    outs = {}
    for name, opt in (("without", None), ("with", {"fll_bandwidth_hz": 0.5, "fll_integration_ms": 10})):
        c = copy.deepcopy(cfg)
        c["zhao_receiver"].pop("pll_lock", None)
        if opt is not None:
            c["zhao_receiver"]["pll_lock"] = opt
        prm = P.zhao_receiver(c)
        sources = prior_sources(ds, 0, prm["receiver"]["variants"], ephs, header, float(prm["receiver"]["prior_eps"]))
        outs[name] = channel(ds, 0, prm, [0, 1], sources)
    return outs


def test_receiver_without_the_option_is_unchanged_and_with_it_adds_only_the_variant(receiver_runs):
    without, with_ = receiver_runs["without"], receiver_runs["with"]
    assert not any(key.startswith("pll_fll") for key in without)
    assert set(with_) - set(without) == {f"pll_fll_{k}" for k in ("phase_error", "frequency_error", "level", "locked", "code_error_chips")}
    for key, value in without.items():  # every other output: the same bits
        np.testing.assert_array_equal(with_[key], value, err_msg=key)
    # the clean part of a 46 dB-Hz channel: the variant is the bare PLL there
    assert with_["pll_fll_locked"][:, :250].all()
    n = 250  # 5 s of bits
    np.testing.assert_array_equal(with_["pll_fll_phase_error"][:, :n], with_["pll_phase_error"][:, :n])


def _receiver_with_pll_fll():
    """The figure tests' synthetic receiver result with a ``pll_fll`` row: bounded frequency, out of lock after the onset + 1 s."""
    import xarray as xr
    from test_zhao_figures import ONSET, _receiver

    res = _receiver()
    fll = res.sel(tracker=["pll"]).assign_coords(tracker=["pll_fll"])
    res = xr.concat([res, fll], dim="tracker", data_vars="minimal", coords="minimal", compat="override")
    t = res["time_bit"].values
    res["example_frequency"].loc[{"tracker": "pll_fll"}] = np.where(t >= ONSET, 8.0 * np.sin(t), 0.05)
    res["sv_freq_var_jammed"].loc[{"tracker": "pll_fll"}] = 36.0
    res["example_pll_fll_locked"] = (("prn", "time_bit"), np.tile((t < ONSET + 1.0).astype(np.int8), (res.sizes["prn"], 1)))
    return res


@pytest.mark.parametrize("name", ["zhao_fig06", "zhao_fig09"])
def test_pll_figures_draw_the_pll_fll_variant_with_its_lost_lock_marked(name):
    from test_zhao_figures import LOCK, _dataset

    from scintrack.products.figure_check import check_figure
    from scintrack.products.figures import zhao_receiver as zr

    res = _receiver_with_pll_fll()
    fig = getattr(zr, name)(res, _dataset(), lock=LOCK)
    assert check_figure(fig) == []
    ax3 = fig.axes[2]
    inside = [ln for ln in ax3.get_lines() if ln.get_color() == zr.COLORS["pll_fll"]]
    out = [ln for ln in ax3.get_lines() if ln.get_color() == zr.FLL_OUT]
    assert len(inside) == 1 and len(out) == 1
    t = np.asarray(inside[0].get_xdata())
    lost = t >= 5.0  # ONSET + 1 s
    assert np.isnan(np.asarray(inside[0].get_ydata(), dtype=float)[lost]).all()  # lost lock is not drawn as the in-lock trace
    if name == "zhao_fig09":
        assert np.isfinite(np.asarray(out[0].get_ydata(), dtype=float)[lost]).all()
    v = zr.verdict_fig09(res, _dataset(), lock=LOCK)
    assert "hold/FLL" in v.text and "6.0 Hz" in v.text


def test_sweep_and_ablation_show_the_pll_fll_variant():
    import xarray as xr

    from scintrack.products.figure_check import check_figure
    from scintrack.products.figures import zhao_receiver as zr

    trackers = ["pll", "pll_fll", "mm_none", "mm_mask", "mm_iode"]
    shape = (len(trackers), 2, 3)
    points = []
    for cn0 in (15.0, 30.0, 40.0):
        lock = np.where(np.arange(len(trackers))[:, None, None] < 2, float(cn0 >= 30.0), 1.0) * np.ones(shape)
        p = xr.Dataset({"phase_rmse_jammed": (("tracker", "prn", "trial"), np.full(shape, 0.2)), "in_lock_jammed": (("tracker", "prn", "trial"), lock),
                        "bit_error_jammed": (("tracker", "prn", "trial"), np.zeros(shape)), "lol_events": (("tracker", "prn", "trial"), np.zeros(shape)),
                        "freq_var_jammed": (("tracker", "prn", "trial"), np.full(shape, 4.0))},
                       coords={"tracker": trackers, "prn": [1, 11], "trial": np.arange(3)})
        p.attrs.update(cn0_jammed_dbhz=cn0, n_trials=3)
        points.append(p)
    fig = zr.zhao_sweep(*points)
    assert check_figure(fig) == []
    assert len(fig.axes[0].containers) == len(trackers)
    assert zr.no_lock_rmse("pll_fll") == zr.no_lock_rmse("pll")  # modulo pi, like the bare PLL
    assert "pll_fll >= 30 dB-Hz" in zr.verdict_sweep(*points).text
    assert check_figure(zr.zhao_ablation(_receiver_with_pll_fll())) == []
