"""Figs. 10-15 of Vila-Valls 2018 (Sec. VI-E) on small hand-made result Datasets.

Each figure must pass the layout check, say which data it shows and give a
verdict with its number; the Fig. 15 lock-loss rule must cut a runaway loop
and keep one that slips and relocks; the Figs. 13-14 "low" panel must be
labelled by its own S4 class and each figure must draw its own component.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from scintrack.products.figure_check import check_figure
from scintrack.products.figures import vila_valls_2018_traces as vt
from scintrack.products.registry import get

BANDS = ["L1", "L2", "L5"]
TRACKERS = ["pll", "kf", "akf", "akf_ar_trace", "aekf_ar_trace"]
LABELS = {"pll": "PLL", "kf": "KF", "akf": "AKF", "akf_ar_trace": "AKF-AR", "aekf_ar_trace": "AEKF-AR"}
TS = 0.01


def _close(fig):
    import matplotlib.pyplot as plt

    plt.close(fig)


def _trace(source="surrogate", seconds=30.0):
    rng = np.random.default_rng(1)
    t = np.arange(0, seconds, TS)
    amp = np.abs(rng.normal(size=(3, t.size)) + 1j * rng.normal(size=(3, t.size))) / np.sqrt(2)
    amp[2, 1234] = 10 ** (-47 / 20)  # a -47 dB fade at L5
    return xr.Dataset({"amplitude": (("band", "time"), amp.astype(np.float32)),
                       "phase": (("band", "time"), rng.normal(size=(3, t.size)).astype(np.float32))},
                      coords={"band": BANDS, "time": t}, attrs={"event": "event1", "source": source})


def _static(seconds=10.0):
    rng = np.random.default_rng(2)
    t = np.arange(0, seconds, TS)
    rho = 1 + 0.2 * np.sin(t)[None, :].repeat(3, 0)
    th = np.cumsum(rng.normal(scale=0.01, size=(3, t.size)), axis=1)
    return xr.Dataset(
        {"example_rho_true": (("band", "time"), rho), "example_rho_hat": (("band", "time"), rho + 0.05),
         "example_theta_true": (("band", "time"), th), "example_theta_hat": (("band", "time"), th + 0.1),
         "rmse_rho": (("band",), [0.05, 0.06, 0.07]), "rmse_theta": (("band",), [0.1, 0.2, 0.3])},
        coords={"band": BANDS, "trial": [0, 1], "time": t},
        attrs={"event": "event1", "source": "surrogate", "cn0_dbhz": 30.0, "tracker_labels": json.dumps({"aekf_ar_static": "AEKF-AR (static)"})},
    )


def _diag(low_s4=0.33, amp_low=None, phase_low=None):
    lags = np.arange(11)
    pacf = np.zeros((3, 2, 11))
    pacf[:, :, 0] = 1.0
    pacf[:, :, 1] = 0.99
    pacf[:, :, 2] = [[-0.8, -0.5], [-0.87, -0.9], [-0.6, -0.6]]
    if amp_low is not None:
        pacf[2, 0, 1:] = amp_low
    if phase_low is not None:
        pacf[2, 1, 1:] = phase_low
    bound = np.full((3, 2, 11), 0.025)
    bound[:, :, 0] = 0.0
    t = np.arange(30.0, 871.0)
    s4 = np.clip(0.8 + 0.2 * np.sin(t / 100.0)[None, None, :] + np.zeros((3, 3, 1)), 0.0, None)
    s4[2, 0, :] = np.linspace(low_s4, 0.9, t.size)
    return xr.Dataset(
        {"s4": (("event", "band", "s4_time"), s4, {"long_name": "S4 over a sliding 60 s window"}),
         "pacf": (("segment", "component", "lag"), pacf), "pacf_bound": (("segment", "component", "lag"), bound),
         "segment_s4": (("segment",), [1.09, 0.44, low_s4]),
         "segment_event": (("segment",), np.array(["event1", "event3", "event3"], dtype=object)),
         "segment_start_s": (("segment",), [480.0, 180.0, 0.0])},
        coords={"event": ["event1", "event2", "event3"], "band": BANDS, "s4_time": t, "segment": ["severe", "moderate", "low"],
                "component": ["amplitude", "phase"], "lag": lags},
        attrs={"segment_s": 60.0, "source": "surrogate"},
    )


def _dynamics(event, seconds=60.0, runaway_at=None):
    rng = np.random.default_rng(3)
    t = np.arange(0, seconds, TS)
    err = rng.normal(scale=0.3, size=(3, 5, t.size))
    if runaway_at is not None:  # the PLL at every band loses lock and runs away under the Doppler rate
        late = t > runaway_at
        err[:, 0, late] += 2 * np.pi * 0.5 * 100.0 * (t[late] - runaway_at) ** 2
    rmse = np.full((3, 5, 2), 1.2)
    return xr.Dataset(
        {"example_error": (("band", "tracker", "time"), err), "example_trial": (("band",), [0, 0, 0]),
         "n_trials": (("band",), [20, 20, 20]), "steady_rmse": (("band", "tracker", "kind"), rmse)},
        coords={"band": BANDS, "tracker": TRACKERS, "kind": ["wrapped", "unwrapped"], "time": t},
        attrs={"event": event, "source": "surrogate", "tracker_labels": json.dumps(LABELS)},
    )


def _render(name, *args, **kwargs):
    product = get(name)
    fig = product.function(*args, **kwargs)
    problems = check_figure(fig)
    verdict = product.verdict(*args, **kwargs)
    texts = [t.get_text() for t in fig.texts]
    _close(fig)
    return problems, verdict, texts


@pytest.mark.parametrize("name, args, kwargs", [
    ("fig10", lambda: (_trace(),), {"start_s": 0.0, "length_s": 20.0}),
    ("fig11", lambda: (_static(),), {"band": "L1"}),
    ("fig12", lambda: (_diag(),), {}),
    ("fig13", lambda: (_diag(),), {"component": "amplitude", "ts": TS}),
    ("fig14", lambda: (_diag(),), {"component": "phase", "ts": TS}),
    ("fig15", lambda: (_dynamics("event1", runaway_at=20.0), _dynamics("event3")), {"cases": [["event1", "L1"], ["event3", "L2"]]}),
    ("fig15", lambda: (_dynamics("event1", seconds=10.0, runaway_at=5.0), _dynamics("event3", seconds=10.0)),
     {"cases": [["event1", "L1"], ["event3", "L2"]]}),  # the smoke build's 10 s
])
def test_trace_figures_pass_the_layout_check_and_name_the_surrogate(name, args, kwargs):
    problems, verdict, texts = _render(name, *args(), **kwargs)
    assert problems == []
    assert any("SYNTHETIC SURROGATE" in t for t in texts)
    assert verdict.status == "not reproduced" and verdict.text.startswith("surrogate data")
    assert any(ch.isdigit() for ch in verdict.text)


def test_real_traces_get_a_verdict_against_the_paper():
    v = vt._fig10_verdict(_trace(source="real"), 0.0, 20.0)
    assert v.status == "differs" and "-47.0 dB" in v.text  # deepest fade 17 dB beyond the paper's -30 dB


def test_fig10_shows_the_deepest_fade_unclipped():
    fig = vt.fig10(_trace(), 0.0, 20.0)
    bottom = fig.axes[2].get_ylim()[0]
    _close(fig)
    assert bottom < -47.0


def test_lock_loss_cuts_a_runaway_and_keeps_a_loop_that_slips():
    t = np.arange(0, 100, TS)
    runaway = np.where(t > 40, 2 * np.pi * 0.5 * 100.0 * (t - 40) ** 2, 0.0)
    assert vt.lock_lost_time(t, runaway) == pytest.approx(40.0, abs=0.5)
    slips = 2 * np.pi * np.floor(t / 15.0)  # one cycle slipped every 15 s, relocked each time
    assert vt.lock_lost_time(t, slips) is None
    # a runaway whose frequency error passes through zero (the Doppler profile turns) has not relocked
    f_err = 20.0 * (t - 70.0)
    turning = np.where(t > 40, 2 * np.pi * np.cumsum(np.where(t > 40, f_err - f_err[t > 40][0], 0.0)) * TS, 0.0)
    assert vt.lock_lost_time(t, turning) == pytest.approx(40.0, abs=1.0)


def test_fig15_draws_wrapped_errors_and_marks_the_lost_loop():
    fig = vt.fig15(_dynamics("event1", runaway_at=20.0), _dynamics("event3"), cases=[["event1", "L1"], ["event3", "L2"]])
    pll = fig.axes[0]
    y = pll.get_lines()[0].get_ydata()
    t = pll.get_lines()[0].get_xdata()
    marks = [a.get_text() for a in pll.texts]
    other = [a.get_text() for a in fig.axes[1].texts]
    _close(fig)
    assert np.nanmax(np.abs(y)) <= np.pi
    assert np.all(np.isnan(y[t > 21.0]))
    assert any(m.startswith("lock lost") for m in marks) and not any(m.startswith("lock lost") for m in other)


def test_pacf_low_panel_is_labelled_by_its_own_class_and_each_figure_draws_its_component():
    amp = np.linspace(0.5, 0.1, 10)
    phase = np.linspace(-0.5, -0.1, 10)
    diag = _diag(low_s4=0.33, amp_low=amp, phase_low=phase)
    figs = {c: vt._pacf(diag, c, 13 if c == "amplitude" else 14, TS) for c in ("amplitude", "phase")}
    low_title = figs["amplitude"].axes[2].get_title()
    drawn = {c: figs[c].axes[2].get_lines()[0].get_ydata() for c in figs}  # the markers outside the band
    for fig in figs.values():
        _close(fig)
    assert "S$_4$ = 0.33 (moderate)" in low_title and "not weak" in low_title
    np.testing.assert_allclose(drawn["amplitude"], amp)
    np.testing.assert_allclose(drawn["phase"], phase)
    assert "no weak" in vt._pacf_verdict(diag, "amplitude").text
    weak = _diag(low_s4=0.2)
    fig = vt._pacf(weak, "phase", 14, TS)
    title = fig.axes[2].get_title()
    _close(fig)
    assert "S$_4$ = 0.20 (low)" in title and "not weak" not in title


def test_fig11_zoom_window_is_marked_on_the_full_panel():
    fig = vt.fig11(_static(), band="L1")
    full, zoom = fig.axes[0], fig.axes[1]
    spans = [p for p in full.patches]
    x0, x1 = zoom.get_xlim()
    _close(fig)
    assert x1 - x0 == pytest.approx(vt.ZOOM_S)
    assert len(spans) == 1
    bbox = spans[0].get_bbox()
    assert bbox.x0 == pytest.approx(x0) and bbox.x1 == pytest.approx(x1, abs=2 * TS)
