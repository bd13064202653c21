"""The fast paths give exactly what the plain paths give.

Each speed-up kept a result bit-identical (or, for the Levinson solve, equal
to the dense solve within rounding); these tests pin that down so a later
"optimisation" cannot silently change a number, and check the progress lines,
the code-version disk cache and the profiler breakdown.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import xarray as xr
from conftest import REPO as ROOT

from scintrack import codeversion
from scintrack.estimators import power_law
from scintrack.progress import Progress
from scintrack.signals import csm, row_blocks


def test_csm_streamed_in_row_blocks_is_bit_identical(monkeypatch):
    kw = dict(seed=3, name="chunks", trials=list(range(5)), n_epochs=700, ts=0.01, s4=0.7, tau0=0.3, nspa=8, warmup=50)
    whole = csm.generate_csm(**kw).z
    monkeypatch.setattr(row_blocks, "CHUNK_BYTES", 16 * 8 * 750 * 2)  # two rows per block, read at call time
    assert len(csm.trial_chunks(5, 750 * 8)) == 3
    assert np.array_equal(csm.generate_csm(**kw).z, whole)
    segs = [csm.Segment(0.0, 0.8, 0.2), csm.Segment(3.0, 0.5, 0.4)]
    prof_small = csm.generate_csm_profile(seed=3, name="p", trials=list(range(5)), n_epochs=700, ts=0.01, segments=segs, nspa=8, warmup=50)[0].z
    monkeypatch.setattr(row_blocks, "CHUNK_BYTES", 1 << 30)
    assert len(csm.trial_chunks(5, 750 * 8)) == 1
    prof_whole = csm.generate_csm_profile(seed=3, name="p", trials=list(range(5)), n_epochs=700, ts=0.01, segments=segs, nspa=8, warmup=50)[0].z
    assert np.array_equal(prof_small, prof_whole)


def test_row_blocked_prompts_and_polar_equal_the_whole_array_expressions(monkeypatch):
    rng = np.random.default_rng(7)
    theta = np.cumsum(rng.normal(size=(7, 500)), axis=1)
    rho = rng.rayleigh(size=(7, 500))
    noise = rng.normal(size=(7, 500)) + 1j * rng.normal(size=(7, 500))
    whole = 0.8 * rho * np.exp(1j * theta) + noise
    whole_scalar = 0.8 * 1.0 * np.exp(1j * theta) + noise
    z = csm.generate_csm(seed=1, name="polar", trials=list(range(7)), n_epochs=500, ts=0.01, s4=0.9, tau0=0.1)
    rho_z, theta_z = np.abs(z.z), np.unwrap(np.angle(z.z), axis=-1)
    monkeypatch.setattr(row_blocks, "CHUNK_BYTES", 16 * 500 * 3)  # three rows per block: 3 + 3 + 1
    from scintrack.signals.correlator import prompts

    assert np.array_equal(prompts(theta, rho, noise, 0.8).view(np.int64), whole.view(np.int64))
    assert np.array_equal(prompts(theta, 1.0, noise, 0.8).view(np.int64), whole_scalar.view(np.int64))
    buf = noise.copy()
    assert prompts(theta, rho, buf, 0.8, out=buf) is buf and np.array_equal(buf.view(np.int64), whole.view(np.int64))
    r, t = z.polar()
    assert np.array_equal(r, rho_z) and np.array_equal(t, theta_z)
    assert np.abs(np.diff(t, axis=-1)).max() <= np.pi  # unwrapped along time in every block


def test_column_nanmedian_kernel_equals_numpy_bit_for_bit():
    from scintrack.experiments.reductions import column_nanmedian_kernel

    rng = np.random.default_rng(3)
    for n in (1, 2, 25, 100):
        v = rng.lognormal(size=(n, 400)) * rng.choice([-1.0, 1.0], size=(n, 400))
        v[rng.random((n, 400)) < 0.2] = np.nan  # odd and even counts per column
        v[:, :5] = np.nan  # all-NaN columns
        v[0, 10] = np.inf
        v[-1, 11] = -np.inf
        v[:, 12] = 2.5  # ties
        out = np.empty(400)
        column_nanmedian_kernel(v, out)
        with np.errstate(all="ignore"), __import__("warnings").catch_warnings():
            __import__("warnings").simplefilter("ignore", RuntimeWarning)
            ref = np.nanmedian(v, axis=0)
        assert np.array_equal(out.view(np.int64), ref.view(np.int64)), n


def _detect_numpy(out):
    """The guards' first-epoch scans as the whole-array numpy expressions they replaced (the reference)."""
    from scintrack.experiments import guards

    theta = np.asarray(out.theta_d)
    nonfinite = np.zeros(theta.shape, dtype=bool)
    for key, v in guards.guarded(out).items():
        nonfinite |= guards._bad(key, v)
    step = np.zeros(theta.shape, dtype=bool)
    for key in ("theta_d", "total_phase"):
        v = out.theta_d if key == "theta_d" else out.extras.get(key)
        if v is not None:
            with np.errstate(invalid="ignore", over="ignore"):
                step[:, 2:] |= np.abs(np.diff(np.asarray(v, dtype=float), n=2, axis=-1)) > guards.STEP_LIMIT_RAD

    def first(mask):
        return np.where(mask.any(axis=-1), np.argmax(mask, axis=-1), -1)

    return first(nonfinite), first(step)


def test_guard_scans_find_the_epochs_the_numpy_masks_find():
    from scintrack.experiments import guards
    from scintrack.trackers.base import TrackOutput

    rng = np.random.default_rng(11)
    n, k = 12, 300
    theta = np.cumsum(rng.normal(scale=0.3, size=(n, k)), axis=1)
    total = theta + 0.1
    freq = rng.normal(size=(n, k))
    theta[1, 40] = np.nan
    theta[2, 50] = 2e12  # a phase beyond the limit
    freq[2, 20] = np.inf  # earlier, in another array
    freq[3, 60] = 5e12  # not a phase: no limit
    theta[4, 70:] += 7.0  # a jump: exploding step at 70 (and 71)
    total[5, 30] = -np.inf
    total[6, 90:] -= 7.0
    theta[7, 10] = np.nan
    theta[7, 200:] += 9.0  # a step after the NaN (around the NaN the differences are NaN: no step there)
    out = TrackOutput(theta_d=theta, extras={"frequency_hz": freq, "total_phase": total, "phi3": np.full((n, k), np.nan)})
    ref_nonfinite, ref_step = _detect_numpy(out)
    div = guards.detect(out)
    assert list(ref_nonfinite[:8]) == [-1, 40, 20, -1, -1, 30, -1, 10] and list(ref_step[[4, 6, 7]]) == [70, 90, 200]
    for t in range(n):  # earliest of the candidates, reasons as the module docstring orders them
        cands = [(e, code) for code, e in ((1, ref_nonfinite[t]), (3, ref_step[t])) if e >= 0]
        want = min(cands, key=lambda c: (c[0], (2, 1, 3).index(c[1]))) if cands else (-1, 0)
        assert (div.epoch[t], div.reason[t]) == want, t


def _held(rng, n=7, k=53, starts=(0, 4, 11, 12, 40)):
    from scintrack.trackers.held_series import HeldSeries

    values = rng.normal(size=(n, len(starts)))
    values[2, 1] = values[5, 3] = np.nan  # a trial without a value in a run
    values[:, 0] = np.nan  # the monitors before their first window: all NaN
    values[3, 2] = np.inf
    return HeldSeries(values, np.array(starts), k)


def test_held_series_reads_as_the_array_it_stands_for():
    from scintrack.trackers.held_series import HeldSeries

    held = _held(np.random.default_rng(5))
    full = np.asarray(held)
    counts = np.diff([0, 4, 11, 12, 40, 53])
    by_loop = np.concatenate([np.repeat(held.values[:, [r]], c, axis=1) for r, c in enumerate(counts)], axis=1)
    assert full.shape == held.shape == (7, 53) and held.dtype == full.dtype and len(held) == 7
    assert np.array_equal(full.view(np.uint64), by_loop.view(np.uint64))
    part = held[2:6]
    assert isinstance(part, HeldSeries) and np.array_equal(np.asarray(part), full[2:6], equal_nan=True)
    assert np.array_equal(held[:, -1], full[:, -1], equal_nan=True) and np.array_equal(held[3], full[3], equal_nan=True)
    for starts, k in (((1, 5), 9), ((0, 5, 5), 9), ((0, 9), 9), ((), 4)):  # not from 0, not rising, past the end, no run
        with pytest.raises(ValueError):
            HeldSeries(np.zeros((2, len(starts))), np.array(starts, dtype=np.int64), k)


def test_trial_reductions_on_held_series_equal_those_on_the_expanded_arrays():
    """The runner's NaN-mean and median over trials, fed a held series in batches, give the bits they give
    on the expanded (trials, epochs) arrays; mixing layouts in one reduction is refused."""
    from scintrack.experiments.runner import NanMean, TrialMedian

    held = _held(np.random.default_rng(9))
    full = np.asarray(held)
    for batches in ((slice(0, 7),), (slice(0, 3), slice(3, 7)), (slice(0, 1), slice(1, 2), slice(2, 7))):
        for make in (NanMean, lambda: TrialMedian(7)):
            on_held, on_full = make(), make()
            for b in batches:
                on_held.add(held[b])
                on_full.add(full[b])
            a, want = on_held.result(), on_full.result()
            assert a.shape == (53,) and np.array_equal(a.view(np.uint64), want.view(np.uint64)), (make, batches)
    mixed = NanMean()
    mixed.add(held[0:3])
    with pytest.raises(ValueError):
        mixed.add(full[3:7])
    other = _held(np.random.default_rng(9), starts=(0, 5, 11, 12, 40))
    with pytest.raises(ValueError):
        mixed.add(other[3:7])


def test_trial_chunks_cover_every_row_once():
    blocks = csm.trial_chunks(11, 1000, budget_bytes=16 * 1000 * 3)
    assert blocks[0] == (0, 3) and blocks[-1] == (9, 11)
    assert [i for lo, hi in blocks for i in range(lo, hi)] == list(range(11))
    assert csm.trial_chunks(2, 10**9, budget_bytes=1) == [(0, 1), (1, 2)]  # at least one row per block


def test_power_law_over_rows_in_one_fft_equals_row_by_row():
    rng = np.random.default_rng(1)
    phi = np.cumsum(rng.normal(size=(6, 3000)), axis=1)
    _, t_all, p_all = power_law.estimate_power_law(phi, 0.001, window_s=3.0)
    for r in range(phi.shape[0]):
        _, t_r, p_r = power_law.estimate_power_law(phi[r], 0.001, window_s=3.0)
        assert t_r.shape == (1,) and t_all[r, 0] == t_r[0] and p_all[r, 0] == p_r[0]
    # the general path (several windows per row) on the same data: same numbers
    _, t_two, p_two = power_law.estimate_power_law(np.concatenate([phi, phi], axis=1), 0.001, window_s=3.0)
    assert np.array_equal(t_two[:, 0], t_all[:, 0]) and np.array_equal(p_two[:, 1], p_all[:, 0])


@pytest.mark.parametrize(("n", "ts", "band"), [(3000, 0.001, (0.5, 5.0)), (300, 0.01, (0.5, 5.0)), (3000, 0.001, (1.5, 15.0))])
def test_power_law_fit_reads_the_rfft_bins_in_place(n, ts, band):
    """The fit from the rfft rows (bins read in place) is the fit of the stored bins taken out as arrays, bit for bit."""
    rng = np.random.default_rng(n)
    spectra = np.fft.rfft(np.cumsum(rng.normal(size=(5, n)), axis=1), axis=-1)
    setup = power_law.spectrum_setup(n, ts, *band)
    t_out, p_out = np.empty(5), np.empty(5)
    power_law._fit_spectra(setup, spectra, t_out, p_out)
    for r in range(5):
        bins = spectra[r, setup.k]
        t_r, p_r = power_law.power_law_fit(setup, np.ascontiguousarray(bins.real), np.ascontiguousarray(bins.imag))
        assert (t_out[r], p_out[r]) == (t_r, p_r)
    assert np.all(np.isfinite(t_out)) and np.all(t_out > 0)


def _tiny_training_set() -> xr.Dataset:
    from scintrack.signals.csm import generate_csm

    z = generate_csm(seed=5, name="t", trials=[0, 1], n_epochs=1500, ts=0.01, s4=0.6, tau0=0.4, nspa=4, warmup=50).z
    amp = np.abs(z)[None]
    phase = np.unwrap(np.angle(z), axis=-1)[None]
    return xr.Dataset({"amplitude": (("tau0", "trial", "time"), amp), "phase": (("tau0", "trial", "time"), phase)},
                      coords={"tau0": [0.4], "trial": [0, 1], "time": np.arange(1500) * 0.01, "s4": 0.6}, attrs={"ts": 0.01})


def test_wrapped_fits_reusing_the_amplitude_fits_are_bit_identical():
    from scintrack.models.lut import fit_training_set

    train = _tiny_training_set()
    args = (4, 6, 0.05, (3.0, 15.0))
    unwrapped = fit_training_set(train, *args)
    direct = fit_training_set(train, *args, wrap_phase=True)
    reused = fit_training_set(train, *args, wrap_phase=True, reuse=unwrapped)
    for name in direct.data_vars:
        assert np.array_equal(direct[name].values, reused[name].values), name
    assert not np.array_equal(direct["trial_coef"].sel(component="phase").values, unwrapped["trial_coef"].sel(component="phase").values)
    with pytest.raises(ValueError, match="another training set"):
        fit_training_set(train, 3, 6, 0.05, (3.0, 15.0), wrap_phase=True, reuse=unwrapped)  # other max_order


def test_code_version_disk_cache_is_keyed_by_content(tmp_path, monkeypatch):
    cache = tmp_path / "cache.json"
    monkeypatch.setenv("SCINTRACK_CODE_CACHE", str(cache))
    codeversion.clear_caches()
    codeversion.clear_disk_cache_memory()
    v1 = codeversion.code_version(["scintrack.progress"])
    entries = json.loads(cache.read_text())
    assert entries and all(set(e) == {"digest", "imports"} for e in entries.values())
    assert oct(cache.stat().st_mode & 0o777) != oct(0o600)  # a normal file mode
    codeversion.clear_caches()
    codeversion.clear_disk_cache_memory()
    assert codeversion.code_version(["scintrack.progress"]) == v1  # from the cache
    # a poisoned entry under another key is never used; a corrupt cache is only a miss
    cache.write_text("{not json")
    codeversion.clear_caches()
    codeversion.clear_disk_cache_memory()
    assert codeversion.code_version(["scintrack.progress"]) == v1
    monkeypatch.setenv("SCINTRACK_CODE_CACHE", "")
    codeversion.clear_caches()
    codeversion.clear_disk_cache_memory()
    assert codeversion.code_version(["scintrack.progress"]) == v1  # no disk cache at all
    codeversion.clear_caches()
    codeversion.clear_disk_cache_memory()


def test_code_version_cache_sees_an_edited_file(tmp_path, monkeypatch):
    monkeypatch.setenv("SCINTRACK_CODE_CACHE", str(tmp_path / "cache.json"))
    script = tmp_path / "job.py"
    script.write_text("x = 1\n")
    codeversion.clear_caches()
    codeversion.clear_disk_cache_memory()
    a = codeversion.code_version([script])
    script.write_text("x = 1  # a comment\n")
    codeversion.clear_caches()
    assert codeversion.code_version([script]) == a
    script.write_text("x = 2\n")
    codeversion.clear_caches()
    assert codeversion.code_version([script]) != a
    codeversion.clear_caches()
    codeversion.clear_disk_cache_memory()


def test_progress_lines_give_rate_and_eta():
    now = [0.0]
    lines: list[str] = []
    prog = Progress(1000, unit="epochs", log=lines.append, label="shard", every_s=10.0, clock=lambda: now[0])
    now[0] = 2.0
    prog.add(100)  # first call: logged
    now[0] = 5.0
    prog.add(150)  # within 10 s of the last line: not logged
    now[0] = 20.0
    prog.add(250)
    now[0] = 21.0
    prog.add(500, note="last")  # complete: always logged
    assert len(lines) == 3
    assert lines[0].startswith("shard: 100/1k epochs (10%), 50 epochs/s") and "ETA 18 s" in lines[0]
    assert "500/1k epochs (50%)" in lines[1] and "ETA 20 s" in lines[1]
    assert "(100%)" in lines[2] and "done" in lines[2] and lines[2].endswith("[last]")
    quiet = Progress(10, unit="x", log=None)
    quiet.add(10)  # no log: nothing happens


def test_profiler_writes_a_breakdown_per_rule(tmp_path):
    job = tmp_path / "job.py"
    job.write_text(textwrap.dedent("""
        import numpy as np
        from scintrack import runlog
        log = runlog.setup(None, "demo_rule")
        from scintrack.signals.correlator import complex_noise
        complex_noise(seed=1, name="x", trials=range(20), n_epochs=200000, power=1.0)
    """))
    env = dict(os.environ, SCINTRACK_PROFILE=str(tmp_path / "prof"))
    subprocess.run([sys.executable, str(job)], check=True, env=env, timeout=120)
    (meta,) = (tmp_path / "prof" / "demo_rule").glob("*.json")
    info = json.loads(meta.read_text())
    assert info["rule"] == "demo_rule" and info["startup_s"] > 0 and info["profiled_s"] > 0
    from scintrack.profiling import breakdown, markdown

    (row,) = breakdown(tmp_path / "prof")
    assert row["jobs"] == 1 and row.get("signal generation", 0) > 0
    assert "| demo_rule | 1 |" in markdown([row])


def test_atomic_outputs_get_a_normal_file_mode(tmp_path):
    from scintrack.io import write_netcdf, write_text

    old = os.umask(0o022)
    try:
        write_text("x", tmp_path / "a.txt")
        write_netcdf(xr.Dataset({"v": ("t", np.arange(3.0))}), tmp_path / "b.nc")
    finally:
        os.umask(old)
    for name in ("a.txt", "b.nc"):
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o644, name
    assert not list(tmp_path.glob(".*"))  # no temporary file left


def _numpys_complex_product_uses_fma() -> bool:
    """Whether numpy's complex multiply on this CPU rounds once per part (x86-64-v3 and later)."""
    from fractions import Fraction

    rng = np.random.default_rng(5)
    a, b = rng.normal(size=64) + 1j * rng.normal(size=64), rng.normal(size=64) + 1j * rng.normal(size=64)
    fused = [float(Fraction(x.real) * Fraction(y.real) + Fraction(-(x.imag * y.imag))) for x, y in zip(a, b)]
    return np.array_equal((a * b).real, fused)


@pytest.mark.parametrize("per, start", [(1, 0), (3, 2), (4, 0), (20, 7), (21, 0), (64, 3), (65, 0), (200, 13), (333, 1)])
def test_derotated_sums_are_numpys_product_and_pairwise_sum(per, start):
    """The lock detector's and the Costas PLL's block sums: numpy's expression on arrays of 256 KiB and more
    (the product computed in the phasor's temporary), bit for bit on an FMA CPU, to rounding elsewhere."""
    from scintrack.experiments.metrics import derotated_sums

    rng = np.random.default_rng(per)
    n = 40 * per + start + 5 if per > 20 else 20_000
    y = rng.normal(0.0, 3.0, (3, n)) + 1j * rng.normal(0.0, 3.0, (3, n))
    phase = rng.normal(0.0, 30.0, (3, n))
    y[1] = 0.0
    nb = (n - start) // per
    assert y.nbytes >= 256 * 1024 or per > 20
    ref = (y[:, start:] * np.exp(-1j * phase[:, start:]))[:, : nb * per].reshape(3, nb, per).sum(axis=-1)
    got = derotated_sums(y, phase, per, start)
    assert got.shape == (3, nb) and got.dtype == complex
    if _numpys_complex_product_uses_fma() and y[:, start:].nbytes >= 256 * 1024:
        assert np.array_equal(got.view(np.uint64), ref.view(np.uint64))
    else:  # small arrays: numpy's product into a new array rounds the imaginary part differently
        assert np.allclose(got, ref, rtol=0.0, atol=1e-12 * per)
    assert np.array_equal(derotated_sums(y, phase, per, start, nb - 1), got[:, : nb - 1])
    with pytest.raises(ValueError, match="do not fit"):
        derotated_sums(y, phase, per, start, nb + 1)
    with pytest.raises(ValueError, match="one shape"):
        derotated_sums(y, phase[:, 1:], per, start)


def test_jamming_prompts_kernel_is_numpys_expression_bit_for_bit():
    from scintrack.experiments import gps_prompts as gp
    from scintrack.signals.gps.correlator import NoiseStream, gains

    rng = np.random.default_rng(2)
    n = 5000
    phi = np.cumsum(rng.normal(size=n)) * 0.01
    cn0 = np.where(np.arange(n) > n // 2, 15.0, 46.0)
    bits = np.repeat(np.sign(rng.normal(size=n // 20)), 20)
    y, noise, sigma = gp.prompts_1ms(NoiseStream(3, "test", 1.0), [0, 4, 9], 1, phi, cn0, bits, 46.0)
    a, s = gains(cn0, gp.CODE_PERIOD_S, "fixed", 46.0)
    ref = (a * bits * np.exp(1j * phi))[None, :] + s * (noise[..., 1] + 1j * noise[..., 4])
    assert np.array_equal(y.view(np.uint64), ref.view(np.uint64)) and np.array_equal(sigma, s)


def test_wrap_is_angle_of_exp_to_the_last_place_and_leaves_in_range_values_alone():
    """The whole-cycle reduction: in-range values untouched, the rest within a few ulps of the exact wrap."""
    from scintrack.experiments.metrics import wrap

    rng = np.random.default_rng(11)
    e = np.concatenate([rng.normal(0.0, s, 200_000) for s in (0.3, 3.0, 40.0, 1e3, 1e5)] + [rng.uniform(-7e6, 7e6, 50_000)])
    edges = [0.0, -0.0, np.pi, -np.pi, np.nextafter(np.pi, 4), -np.nextafter(np.pi, 4), 2 * np.pi, 3 * np.pi, -3 * np.pi, 1e9, -1e15]
    e = np.concatenate([edges, e])
    w = wrap(e)
    assert w.min() >= -np.pi and w.max() <= np.pi
    inside = np.abs(e) <= np.pi
    assert np.array_equal(w[inside], e[inside])  # a loop in lock: its errors as they are
    with np.errstate(invalid="ignore"):
        ref = np.angle(np.exp(1j * e))
    d = np.abs(w - ref)
    d = np.minimum(d, 2 * np.pi - d)  # -pi and pi are the same angle
    assert d.max() <= 5e-16, d.max()  # ~1 ulp at pi (4.4e-16); libm's own route is off by as much
    cycles = (e - w) / (2 * np.pi)  # whole periods removed, nothing else
    assert np.max(np.abs(cycles - np.round(cycles))[np.abs(e) < 1e3]) < 1e-12
    grid = e[: 6 * 3000].reshape(6, 3000)
    assert np.array_equal(wrap(grid[:, 5:900]), w[: 6 * 3000].reshape(6, 3000)[:, 5:900])  # a strided view
    assert np.all(np.isnan(wrap(np.array([np.nan, np.inf, -np.inf]))))
    assert wrap(3.5) == -2.7831853071795867 and np.ndim(wrap(3.5)) == 0  # 3.5 - 2 pi = -2.78318530717958648 rounded
    assert wrap(-np.pi) == -np.pi and wrap(np.pi) == np.pi


@pytest.mark.parametrize("shards", [1, 2])
def test_scenario_result_is_its_blocks_written_read_and_merged(tmp_path, shards):
    """The experiment job's result of a scenario equals its blocks of trials run as separate shards, each written to a
    file and read back, then merged (what separate shard and merge jobs would give), bit for bit."""
    from test_aekf_study import _tiny_lut

    from scintrack.batching import trial_blocks
    from scintrack.config import load_config
    from scintrack.experiments.merge import merged_result
    from scintrack.experiments.shard_job import scenario_result, shard_result
    from scintrack.io import content_hash, open_dataset, write_netcdf
    from scintrack.pipeline import params

    config = load_config([ROOT / "config" / "config.yaml", ROOT / "config" / "smoke.yaml"])
    config["experiments"]["case1_free"].update(trials=3, shards=shards)
    run = params.experiment(config, "case1_free", "free")
    lut = tmp_path / "lut.nc"
    write_netcdf(_tiny_lut(), lut)
    one = scenario_result(run, lut=str(lut), inputs=[str(lut)])
    blocks = trial_blocks(3, shards)
    assert sorted(t for b in blocks for t in b) == [0, 1, 2] and len(blocks) == shards
    files = []
    for k, trials in enumerate(blocks):
        files.append(tmp_path / f"shard-{k}.nc")
        write_netcdf(shard_result({**run, "trials": trials}, trials, lut=str(lut), inputs=[str(lut)]), files[-1])
    two = merged_result([open_dataset(f) for f in files], run, [str(f) for f in files])
    assert content_hash(one) == content_hash(two)
    assert sorted(one.variables) == sorted(two.variables)
    for name in one.variables:
        assert one[name].dtype == two[name].dtype and np.array_equal(one[name].values, two[name].values, equal_nan=one[name].dtype.kind in "fc"), name
    assert one.attrs["config_sha256"] == two.attrs["config_sha256"] and one.attrs["title"] == two.attrs["title"]


def test_lut_lookups_are_xarrays_nearest_selection():
    """scintillation_ar / lookup / nearest_point pick what ``lut.sel(..., method="nearest")`` picks, value for value."""
    import xarray as xr

    from scintrack.models.lut import AMPLITUDE_ORDER, TABLE_I_PHASE_ORDER, lookup, nearest_point, scintillation_ar
    from scintrack.models.regions import region_of

    rng = np.random.default_rng(5)
    s4, tau0 = [0.1, 0.2, 0.5, 0.9, 1.0], [0.1, 0.4, 0.8]
    shape = (len(s4), len(tau0), 2, 4)
    lut = xr.Dataset(
        {"coef": (("s4", "tau0", "component", "order", "lag"), rng.normal(size=shape + (4,))),
         "const": (("s4", "tau0", "component", "order"), rng.normal(size=shape)),
         "sigma2": (("order", "component", "tau0", "s4"), rng.uniform(size=shape[::-1]))},  # another axis order
        coords={"s4": s4, "tau0": tau0, "component": ["amplitude", "phase"], "order": [1, 2, 3, 4], "lag": [1, 2, 3, 4]},
    )
    points = [(a, b) for a in (0.1, 0.15, 0.3, 0.35, 0.7, 0.95, 1.4) for b in (0.05, 0.25, 0.6, 0.4, 2.0)]
    for a, b in points:
        ref = lut.sel(s4=a, tau0=b, method="nearest")
        assert nearest_point(lut, a, b) == (float(ref["s4"]), float(ref["tau0"]))
        for comp, order in (("amplitude", AMPLITUDE_ORDER), ("phase", 2), ("phase", 4)):
            one = ref.sel(component=comp, order=order)
            got = lookup(lut, a, b, comp, order)
            assert np.array_equal(got.coefs, one["coef"].values[:order]) and got.const == float(one["const"]) and got.sigma2 == float(one["sigma2"])
        pair = scintillation_ar(lut, a, b)
        p = TABLE_I_PHASE_ORDER[region_of(a)]
        assert np.array_equal(pair.phase.coefs, ref.sel(component="phase", order=p)["coef"].values[:p])
        assert (pair.s4, pair.tau0) == nearest_point(lut, a, b)
    with pytest.raises(KeyError):
        lookup(lut, 0.5, float("nan"), "phase", 1)
