"""The jamming receiver on a short jammed scenario: what the paper claims, measured on a few trials.

- the Costas PLL loses lock after the onset while the MM filter with bit
  prediction keeps it (lock detector of ``zhao_receiver.lock``);
- the ephemeris decoded from the PLL's own bit decisions in the clean part
  equals the encoded one, bit for bit;
- an upload during jamming makes the IODE-check prediction wrong in some bits
  (the receiver cannot know), while the upload-robust mask never is.
"""

import copy

import numpy as np
import pytest
from test_gps_dataset import small_config

from scintrack.data.gps_jamming_build import build
from scintrack.data.gps_jamming_spec import gps_jamming_params
from scintrack.experiments import gps_prompts as gp
from scintrack.experiments.gps_channel_result import channel_result
from scintrack.experiments.gps_receiver import channel, decoded_ephemeris, held_1ms, prior_sources
from scintrack.pipeline import params as P
from scintrack.project import project_file
from scintrack.signals.gps import ephemeris, lnav, message

RINEX = project_file("data/ephemerides/brdc2800.15n")
ONSET = 40.0  # the clean part holds one whole frame (frames start at 13 s and 43 s of this scenario)


@pytest.fixture(scope="module")
def run():
    cfg = small_config(duration_s=70.0, uploads=[{"prn": 1, "time_s": 41.0}], message_lead_s=780.0)
    cfg["gps_jamming"]["jammer"] = {**cfg["gps_jamming"]["jammer"], "onset_s": ONSET}
    cfg = copy.deepcopy(cfg)
    cfg["zhao_receiver"].update(trials=3)
    ds = build(gps_jamming_params(cfg), RINEX)
    prm = P.zhao_receiver(cfg)
    ephs, header = ephemeris.load(RINEX), ephemeris.read_header(RINEX)
    k = int(np.flatnonzero(ds["prn"].values == 1)[0])
    sources = prior_sources(ds, k, prm["receiver"]["variants"], ephs, header, float(prm["receiver"]["prior_eps"]))
    out = channel(ds, k, prm, [0, 1, 2], sources)
    start = int(out["start_epoch"])
    t20 = ds["receive_time"].isel(sv=k).values[start :: gp.BIT_MS][: out["pll_phase_error"].shape[1]]
    return ds, k, prm, out, t20


def _locked(err, prm):
    lock = prm["receiver"]["lock"]
    return gp.lock_state(err, gp.BIT_MS * gp.CODE_PERIOD_S, float(lock["threshold_rad"]), float(lock["window_s"]))


def test_pll_loses_lock_and_the_mm_filter_with_prediction_does_not(run):
    ds, k, prm, out, t20 = run
    jammed = t20 >= ONSET + 2.0
    clean = t20 < ONSET
    pll = _locked(out["pll_phase_error"], prm)
    assert pll[:, clean & (t20 > 2.0)].all()  # locked before the jammer
    assert pll[:, jammed].mean() < 0.8  # and out of lock for a good part of the jammed time
    mm = _locked(out["mm_mask_phase_error"], prm)
    assert mm[:, jammed].mean() > 0.95
    assert np.sqrt(np.mean(out["mm_mask_phase_error"][:, jammed] ** 2)) < 0.5
    assert np.sqrt(np.mean(out["pll_phase_error"][:, jammed] ** 2)) > 0.6  # Costas error modulo pi, uniform: 0.91


def test_ephemeris_decoded_from_the_pll_decisions_equals_the_encoded_one(run):
    ds, k, prm, out, t20 = run
    clean = t20 < ONSET
    levels = out["pll_level"][0, clean]
    bits = (levels < 0).astype(np.int8)
    decoded = [s for s in message.decode_message(bits) if s.subframe_id in (1, 2, 3)]
    assert len(decoded) >= 3 and all(s.ok for s in decoded)  # parity holds on every word (Costas sign resolved by the preamble)
    truth = decoded_ephemeris(ds, k)  # from the transmitted bits before the start: the data set in force
    for s in decoded:
        for name in lnav.FIELDS[s.subframe_id]:
            assert s.fields[name] == pytest.approx(truth.fields[name], rel=0, abs=1e-30), name


def test_upload_during_jamming_gives_wrong_iode_predictions_but_never_wrong_mask_predictions(run):
    ds, k, prm, out, t20 = run
    assert out["mm_mask_prediction_wrong"].sum() == 0
    assert out["mm_mask_predicted"][:, t20 >= ONSET].mean() > 0.3
    upload = t20 >= float(ds["subframe_start"].values[np.flatnonzero(ds["dataset_kind"].isel(sv=k).values == "upload")[0]])
    assert out["mm_iode_prediction_wrong"][:, upload].sum() > 0
    assert out["mm_iode_prediction_wrong"][:, ~upload].sum() == 0


def test_memoised_priors_equal_a_fresh_predictor_per_trial(run):
    """PriorSource shares predictor states between trials with the same decided frames; every trial's priors must
    equal those of a predictor fed that trial's frames alone (the sequential receiver, trial by trial)."""
    from scintrack.experiments.gps_receiver import FRAME_BITS
    from scintrack.signals.gps import bit_prediction

    ds, k, prm, out, t20 = run
    ephs, header = ephemeris.load(RINEX), ephemeris.read_header(RINEX)
    source = prior_sources(ds, k, ["mm_iode"], ephs, header, float(prm["receiver"]["prior_eps"]))["mm_iode"]
    truth = (out["true_level"] < 0).astype(np.int8)
    rng = np.random.default_rng(5)
    trials = [truth, truth.copy()]  # a repeat: served from the memo
    for n_flips in (1, 3, 40):
        d = truth.copy()
        d[rng.choice(d.size, n_flips, replace=False)] ^= 1
        trials += [d, truth.copy()]
    # an IODE copy of the first scenario frame decided wrongly: the next frame falls back to the mask
    iode = [int(np.flatnonzero(source.nav_idx == source.first * FRAME_BITS + p)[0]) for p in bit_prediction.IODE_POSITIONS
            if source.first * FRAME_BITS + p in source.nav_idx]
    assert iode and source.last > source.first
    d = truth.copy()
    d[iode[0]] ^= 1
    trials += [d, truth.copy()]
    got = [source.priors(d) for d in trials]

    def reference(decisions):
        predictor = bit_prediction.BitPredictor("iode", source.robust, eps=float(prm["receiver"]["prior_eps"]))
        history = ds["nav_bits"].isel(sv=k).values[: source.nav_idx[0]]
        for j in range(source.first):
            predictor.observe(history[j * FRAME_BITS : (j + 1) * FRAME_BITS])
        full = np.full(source.robust.n_frames * FRAME_BITS, -1, dtype=np.int8)
        full[source.first * FRAME_BITS : source.first * FRAME_BITS + len(source.head)] = source.head
        full[source.nav_idx] = decisions
        stream = np.full(full.size, 0.5)
        for j in range(source.first, source.last + 1):
            stream[j * FRAME_BITS : (j + 1) * FRAME_BITS] = predictor.priors(j)
            frame = full[j * FRAME_BITS : (j + 1) * FRAME_BITS]
            if not np.all(frame >= 0):
                break
            predictor.observe(frame)
        return stream[source.nav_idx]

    for d, g in zip(trials, got):
        assert np.array_equal(g, reference(d))
    assert not np.array_equal(got[-2], got[0])  # the wrong IODE copy changed the next frame's priors


def test_channel_holds_one_trackers_1ms_arrays_at_a_time(run):
    """Peak memory of a channel (a full-size Zhao channel job reached 2.05 GiB).  Each carrier
    tracker's DLL runs as soon as that tracker's 1-ms phase and frequency exist and they are dropped after it,
    instead of holding the DLL inputs of all four trackers (8 arrays of (trials, 1-ms epochs)) and the 1-ms
    prompts until the end.  Measured here in units of one float64 (trials, epochs) array: 30.5 before, 24.0
    after (the E/P/L noise alone is 6); the bound sits between, so going back to the old layout fails it."""
    import tracemalloc

    ds, k, prm, out, _ = run
    ephs, header = ephemeris.load(RINEX), ephemeris.read_header(RINEX)
    sources = prior_sources(ds, k, prm["receiver"]["variants"], ephs, header, float(prm["receiver"]["prior_eps"]))
    unit = 3 * ds.sizes["epoch"] * 8  # one float64 (trials, epochs) array of the three trials
    tracemalloc.start()
    try:
        again = channel(ds, k, prm, [0, 1, 2], sources)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert all(np.array_equal(again[key], out[key]) for key in out)  # the same channel, bit for bit
    assert peak < 27 * unit, f"peak {peak / unit:.1f} units of (trials, epochs) float64"


def test_fig4_map_from_the_channels_prediction_equals_its_own_short_span_prediction(run):
    """The channel reuses its upload-robust prediction (to the scenario's end + 30 s) for the Fig. 4 map, which
    needs only the frames up to the scenario start: the map must equal the one from a prediction over
    [start, t0 + 30 s] (fewer frames, fewer upload alternatives), and the shared prefix must be the same bits."""
    from scintrack.experiments.gps_channel_result import _prediction_map, start_prediction

    ds, k, prm, _, _ = run
    ephs, header = ephemeris.load(RINEX), ephemeris.read_header(RINEX)
    sources = prior_sources(ds, k, prm["receiver"]["variants"], ephs, header, float(prm["receiver"]["prior_eps"]))
    shared = next(s.robust for s in sources.values() if s.robust is not None)
    short = start_prediction(ds, k, ephs, header)  # what the map is computed from without a shared prediction
    own = _prediction_map(ds, k, ephs, header, short)
    reused = _prediction_map(ds, k, ephs, header, shared)
    for a, b in zip(own, reused):
        np.testing.assert_array_equal(a, b)
    assert short.t0 == shared.t0 and short.n_frames < shared.n_frames and short.n_alternatives < shared.n_alternatives
    n = short.bits.size
    np.testing.assert_array_equal(short.bits, shared.bits[:n])
    np.testing.assert_array_equal(short.mask, shared.mask[:n])
    assert not shared.mask[n:].all()  # the later frames have bits an upload changes: the prefix check is not vacuous


def test_channel_result_does_not_depend_on_the_trial_batch(run):
    """``trial_batch`` bounds a channel job's memory; every output, ``rmse_t`` included, is the same bits for any batch."""
    ds, k, prm, out, t20 = run
    assert "trial_batch" not in prm["receiver"]  # a resource of the rules, not a param: changing it reruns nothing
    results = [channel_result(ds, 1, prm, RINEX, trials=3, trial_batch=batch) for batch in (3, 2)]
    for name in results[0].data_vars:
        np.testing.assert_array_equal(results[0][name].values, results[1][name].values, err_msg=name)


def test_bit_prediction_file_gives_the_channels_own_prediction_and_result(run, tmp_path):
    """The rule zhao_bit_prediction's file (every satellite, written and read back as NetCDF) holds each channel's
    upload-robust prediction, the same arrays and fields; a channel given it gives the same bits as one that
    computes its own; a file made for another span is refused."""
    from scintrack.experiments import gps_bit_prediction as gbp
    from scintrack.io import open_dataset, write_netcdf

    ds, k, prm, out, t20 = run
    ephs, header = ephemeris.load(RINEX), ephemeris.read_header(RINEX)
    path = tmp_path / "bit_prediction.nc"
    write_netcdf(gbp.predictions(ds, ephs, header), path)
    pred = open_dataset(path)
    assert sorted(pred["prn"].values.tolist()) == sorted(ds["prn"].values.tolist())
    for j in range(ds.sizes["sv"]):
        own, read = gbp.channel_prediction(ds, j, ephs, header), gbp.prediction_of(pred, ds, j)
        assert (read.prn, read.week, read.t0, read.n_alternatives) == (own.prn, own.week, own.t0, own.n_alternatives)
        for name in ("bits", "mask"):
            a, b = getattr(own, name), getattr(read, name)
            assert a.dtype == b.dtype and np.array_equal(a, b), name
        assert 0 < own.mask.sum() < own.mask.size  # some bits predicted, some not: the comparison is not vacuous
    given = channel_result(ds, 1, prm, RINEX, trials=2, prediction=pred)
    alone = channel_result(ds, 1, prm, RINEX, trials=2)
    for name in alone.data_vars:
        np.testing.assert_array_equal(given[name].values, alone[name].values, err_msg=name)
    shifted = ds.assign_attrs(duration_s=float(ds.attrs["duration_s"]) + 60.0)
    with pytest.raises(ValueError, match="rerun zhao_bit_prediction"):
        gbp.prediction_of(pred, shifted, k)


@pytest.mark.parametrize(("start", "n_bits", "after"), [(7, 10, 5), (0, 10, 0), (19, 3, 18), (0, 1, 0)])
def test_held_1ms_is_the_padded_repeat_of_the_20ms_values(start, n_bits, after):
    v = np.random.default_rng(start).normal(size=(4, n_bits))
    ref = np.pad(np.repeat(v, 20, axis=1), ((0, 0), (start, after)), mode="edge")
    np.testing.assert_array_equal(held_1ms(v, start, start + 20 * n_bits + after), ref)
