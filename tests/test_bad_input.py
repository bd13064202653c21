"""The bad-input catalogue: every case is run as a user would run it and must

* exit non-zero,
* print exactly one ``error:`` line, which names the file or config key and
  says what to do (the case lists words the line must contain),
* print no Python traceback, and
* leave every output that existed before unchanged (same bytes, same mtime).

Cases run ``snakemake`` on a copy of a small finished smoke workdir (the
AR look-up table and its inputs: outputs to protect), ``repro.py run`` where
only it can name the file (a YAML error in an overlay: Snakemake's own
message does not), or a workflow-script-like entry point (``python -c`` with
:func:`scintrack.runlog.setup`, i.e. the hook every workflow script has) for
readers whose rule needs a long chain to reach.  Snakemake's own job-failure
summary ("Error in rule ...", the log path) surrounds the line when a job
fails; it is Snakemake's and names no Python frame.

The trace reader's format checks run through the ``trace_dataset`` job's own
reader call (``via="reader"``: the same ``load_trace`` with the bands and
sampling period the rule passes, under the same hook) once each container has
one case that goes through Snakemake end to end (``trace_nan``: npz,
``trace_inf_netcdf``: NetCDF, which also cover the job's renaming of the
verified copy to the user's file).  Each Snakemake case costs two job processes
and a Snakemake start-up, ~2.7 CPU-s against ~0.8.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from conftest import REPO, SNAKEMAKE, cores_per_worker, snakemake_cmd, snakemake_env
from conftest import registry_text as registry_text_of

pytestmark = pytest.mark.pipeline

BASE_TARGET = "results/ar_models/ar_lut.nc"
TRACE_TARGET = "data/traces/real/event1.nc"
EVENTS = ("event1", "event2", "event3")
BANDS = ("L1", "L2", "L5")
TS = 0.01
ROOTS = ("data", "results", "figures", "tables")


@dataclass
class Case:
    """One bad input: how to make it, what to run, what the error line must say."""

    name: str
    expect: tuple[str, ...]
    overlay: dict | str | None = None  # mapping, or raw YAML text
    targets: tuple[str, ...] = ()  # empty: a dry run of everything (-n)
    setup: Callable[[Path, Path], dict | None] | None = None  # (workdir, tmp) -> overlay additions
    via: str = "snakemake"  # or "repro", "script", "reader" (the trace_dataset job's reader on the overlay's event1 file)
    script: str = ""  # for via="script": python code run after runlog.setup; {tmp} is formatted
    extra: tuple[str, ...] = ()
    env: dict = field(default_factory=dict)
    preexec: Callable[[], None] | None = None


# --- inputs the cases are made from --------------------------------------------------------


def _trace_arrays(n: int = 6000, seed: int = 1) -> dict[str, np.ndarray]:
    """A valid trace in the documented layout (docs/data.md): 60 s at 10 ms, three bands."""
    rng = np.random.default_rng(seed)
    arrays = {"time": 100.0 + TS * np.arange(n)}
    for band in BANDS:
        arrays[f"amplitude_{band}"] = np.sqrt(rng.exponential(1.0, n) * 0.3 + 0.7)
        arrays[f"phase_{band}"] = np.cumsum(rng.normal(0, 0.02, n))
    return arrays


def _save(path: Path, arrays: dict[str, np.ndarray], units: dict[str, str] | None = None) -> Path:
    suffix = path.suffix
    if suffix == ".npz":
        np.savez(path, **arrays)
    elif suffix == ".csv":
        cols = list(arrays)
        np.savetxt(path, np.column_stack([arrays[c] for c in cols]), delimiter=",", header=",".join(cols), comments="")
    elif suffix == ".nc":
        units = units or {}
        ds = xr.Dataset({k: ("time", v, {"units": units.get(k, "s" if k == "time" else "rad" if k.startswith("phase") else "1")})
                         for k, v in arrays.items() if k != "time"},
                        coords={"time": ("time", arrays["time"], {"units": units.get("time", "s")})})
        ds.to_netcdf(path)
    elif suffix == ".mat":
        from scipy.io import savemat

        savemat(path, arrays)
    else:
        path.write_bytes(b"not a trace")
    return path


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _traces(tmp: Path, file: Path, sha: str | None = None, registry_text: str | None = None, source: dict | None = None) -> dict:
    """Overlay: every event read from ``file`` (or ``source``), its sha256 in a registry of the test's own."""
    registry = tmp / "registry.yaml"
    if registry_text is None:
        registry_text = registry_text_of({f"jrc_hanoi_{e}": {"sha256": sha or _sha(file)} for e in EVENTS})
    registry.write_text(registry_text)
    src = source or {"path": str(file)}
    return {"real_traces": {"registry": str(registry), "sources": {e: dict(src) for e in EVENTS}}}


def trace_case(kind: str) -> Callable[[Path, Path], dict]:
    def setup(work: Path, tmp: Path) -> dict:
        arrays = _trace_arrays()
        if kind == "nan":
            arrays["amplitude_L2"][123] = np.nan
            return _traces(tmp, _save(tmp / "ev.npz", arrays))
        if kind == "inf":
            arrays["phase_L5"][77] = np.inf
            return _traces(tmp, _save(tmp / "ev.nc", arrays))
        if kind == "nonmonotonic":
            arrays["time"][2000] = arrays["time"][1990]
            return _traces(tmp, _save(tmp / "ev.npz", arrays))
        if kind == "truncated":
            path = _save(tmp / "ev.npz", arrays)
            path.write_bytes(path.read_bytes()[: path.stat().st_size // 3])
            return _traces(tmp, path)
        if kind == "corrupt_nc":
            path = _save(tmp / "ev.nc", arrays)
            raw = bytearray(path.read_bytes())
            raw[:64] = b"\0" * 64
            path.write_bytes(bytes(raw))
            return _traces(tmp, path)
        if kind == "units":
            return _traces(tmp, _save(tmp / "ev.nc", arrays, units={"phase_L1": "deg"}))
        if kind == "missing_var":
            del arrays["phase_L2"]
            return _traces(tmp, _save(tmp / "ev.nc", arrays))
        if kind == "dims":
            path = tmp / "ev.nc"
            xr.Dataset({k: (("time", "x"), np.tile(v[:, None], (1, 2))) for k, v in arrays.items() if k != "time"},
                       coords={"time": arrays["time"]}).to_netcdf(path)
            return _traces(tmp, path)
        if kind == "csv_garbage":
            path = tmp / "ev.csv"
            path.write_text("time,amplitude_L1\n0.0,abc\n1.0,\x00\x00\n")
            return _traces(tmp, path)
        if kind == "mat_corrupt":
            path = _save(tmp / "ev.mat", arrays)
            path.write_bytes(path.read_bytes()[:200])
            return _traces(tmp, path)
        if kind == "container":
            return _traces(tmp, _save(tmp / "ev.xyz", arrays))
        if kind == "missing_file":
            return _traces(tmp, tmp / "nosuch.npz", sha="0" * 64)
        if kind == "wrong_sha":
            return _traces(tmp, _save(tmp / "ev.npz", arrays), sha="1" * 64)
        if kind == "no_sha":
            return _traces(tmp, _save(tmp / "ev.npz", arrays), registry_text=registry_text_of({}))
        if kind == "url":
            return _traces(tmp, tmp / "x", sha="0" * 64, source={"url": "http://127.0.0.1:9/event.nc"})
        if kind == "registry_yaml":
            return _traces(tmp, _save(tmp / "ev.npz", arrays), registry_text="datasets: [1\n")
        if kind == "registry_sha":
            return _traces(tmp, _save(tmp / "ev.npz", arrays), registry_text="datasets:\n  jrc_hanoi_event1: {sha256: abc}\n")
        raise AssertionError(kind)

    return setup


def _corrupt_fit(work: Path, tmp: Path) -> None:
    """An intermediate result truncated (e.g. a disk that filled up outside the pipeline): its reader names it."""
    fit = work / "results" / "ar_models" / "fits" / "s4-0.3.nc"
    fit.write_bytes(fit.read_bytes()[:500])
    (work / BASE_TARGET).unlink()


def _remove_training(work: Path, tmp: Path) -> Path:
    """The S4 = 0.5 training set and what depends on it removed, so the run has to write it again."""
    folder = work / "data" / "synthetic" / "csm_train_s4-0.5"
    for f in folder.iterdir():
        f.unlink()
    (work / "results" / "ar_models" / "fits" / "s4-0.5.nc").unlink()
    (work / BASE_TARGET).unlink()
    return folder


def _disk_full(work: Path, tmp: Path) -> None:
    _remove_training(work, tmp)


def _read_only(work: Path, tmp: Path) -> None:
    _remove_training(work, tmp).chmod(0o555)


def _drop_dac() -> None:
    """As root, give up the capability that ignores file modes, so a read-only folder is read-only."""
    if os.geteuid() == 0:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_capbset_drop = 24
        for cap in (1, 2):  # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH
            libc.prctl(pr_capbset_drop, cap, 0, 0, 0)


def _file_limit() -> None:
    import resource

    resource.setrlimit(resource.RLIMIT_FSIZE, (64 * 1024, 64 * 1024))  # 64 KB: a NetCDF output does not fit


IQ_SCRIPT = """
from pathlib import Path
import numpy as np
from scintrack.signals.gps import iq
tmp = Path({tmp!r})
rec = tmp / "rec.bin"
iq.write_recording(rec, np.exp(1j * np.arange(4000) * 0.01), iq.make_sidecar([], fs=2.046e6, duration_s=4000 / 2.046e6, seed=1,
                   gps_week=1864, gps_seconds_of_week=0.0))
{mutate}
iq.read_recording(rec)
"""


def iq_script(mutate: str) -> str:
    return IQ_SCRIPT.replace("{mutate}", mutate)


CASES = [
    # --- schema bounds and types
    Case("bound_bandwidth", ("tracking.pll_bandwidth_hz", "minimum", "overlay.yaml"), {"tracking": {"pll_bandwidth_hz": -3}}),
    Case("bound_trials", ("experiments.cycle_slips.trials", "overlay.yaml"), {"experiments": {"cycle_slips": {"trials": 0}}}),
    Case("bound_ts", ("sampling.ts", "overlay.yaml"), {"sampling": {"ts": 0}}),
    Case("bound_s4", ("s4", "overlay.yaml"), {"ar_training": {"s4": [0.3, 0.5, 1.6]}}),
    Case("bound_tau0", ("tau0", "overlay.yaml"), {"ar_training": {"tau0": [-0.1]}}),
    Case("type_seed", ("seed", "overlay.yaml"), {"seed": "abc"}),
    Case("nan_value", ("tracking.cn0_dbhz", "not a finite number", "overlay.yaml"), "tracking:\n  cn0_dbhz: .nan\n"),
    Case("inf_value", ("tracking.q_jerk_hz2_s3", "not a finite number"), "tracking:\n  q_jerk_hz2_s3: .inf\n"),
    Case("command_line_value", ("tracking.pll_bandwidth_hz", "--config"), extra=("--config", 'tracking={"pll_bandwidth_hz": -1}')),
    # --- unknown keys, trackers, scenarios, tracker types; a tracker where it cannot run
    Case("unknown_top_key", ("nosuchkey", "unknown key", "remove or rename", "overlay.yaml"), {"nosuchkey": 1}),
    Case("unknown_nested_key", ("tracking.pll_bandwdth_hz", "unknown key", "overlay.yaml"), {"tracking": {"pll_bandwdth_hz": 1}}),
    Case("unknown_tracker", ("experiments.cycle_slips.trackers", "nosuch", "overlay.yaml"), {"experiments": {"cycle_slips": {"trackers": ["nosuch"]}}}),
    Case("unknown_scenario", ("experiments.cycle_slips.scenarios", "nosuch", "overlay.yaml"), {"experiments": {"cycle_slips": {"scenarios": ["nosuch"]}}}),
    Case("unknown_tracker_type", ("trackers.mine", "type", "overlay.yaml"), {"trackers": {"mine": {"type": "nosuch"}}}),
    Case("scenario_missing_key", ("scenarios.extra", "segments", "overlay.yaml"), {"scenarios": {"extra": {"duration_s": 5}}}),
    Case("shards_gt_trials", ("experiments.cycle_slips.shards", "overlay.yaml"), {"experiments": {"cycle_slips": {"shards": 50, "trials": 4}}}),
    Case("trace_tracker_on_csm", ("cycle_slips", "trace", "overlay.yaml"), {"experiments": {"cycle_slips": {"trackers": ["aekf_ar_trace"]}}}),
    # --- config files themselves
    Case("overlay_yaml_syntax", ("overlay.yaml:2", "not valid YAML"), "tracking:\n  pll_bandwidth_hz: 1: 2\n", via="repro"),
    Case("overlay_not_mapping", ("overlay.yaml", "mapping"), "- 1\n- 2\n", via="repro"),
    Case("overlay_missing", ("nosuch.yaml", "not found"), None, via="repro", extra=("--configfile", "nosuch.yaml")),
    Case("main_config_yaml_syntax", ("config.yaml", "not valid YAML"), None, via="main_yaml"),
    # --- real traces: every container, every check
    Case("trace_nan", ("ev.npz", "amplitude_L2", "non-finite"), setup=trace_case("nan"), targets=(TRACE_TARGET,)),
    Case("trace_inf_netcdf", ("ev.nc", "phase_L5", "non-finite"), setup=trace_case("inf"), targets=(TRACE_TARGET,)),
    Case("trace_nonmonotonic", ("ev.npz", "time"), setup=trace_case("nonmonotonic"), via="reader"),
    Case("trace_truncated_npz", ("ev.npz",), setup=trace_case("truncated"), via="reader"),
    Case("trace_corrupt_netcdf", ("ev.nc",), setup=trace_case("corrupt_nc"), via="reader"),
    Case("trace_units", ("ev.nc", "phase_L1", "deg"), setup=trace_case("units"), via="reader"),
    Case("trace_missing_variable", ("ev.nc", "phase_L2", "missing"), setup=trace_case("missing_var"), via="reader"),
    Case("trace_wrong_dims", ("ev.nc",), setup=trace_case("dims"), via="reader"),
    Case("trace_csv_garbage", ("ev.csv",), setup=trace_case("csv_garbage"), via="reader"),
    Case("trace_mat_corrupt", ("ev.mat",), setup=trace_case("mat_corrupt"), via="reader"),
    Case("trace_unknown_container", ("real_traces.sources.event1", "ev.xyz", "format"), setup=trace_case("container"), targets=(TRACE_TARGET,)),
    Case("trace_missing_file", ("nosuch.npz", "no such file", "real_traces.sources"), setup=trace_case("missing_file"), targets=(TRACE_TARGET,)),
    Case("trace_wrong_sha256", ("sha256 mismatch", "moved aside"), setup=trace_case("wrong_sha"), targets=(TRACE_TARGET,)),
    Case("trace_no_sha256", ("no sha256", "registry.yaml"), setup=trace_case("no_sha"), targets=(TRACE_TARGET,)),
    Case("trace_unreachable_url", ("127.0.0.1:9", "unreachable", "real_traces.sources"), setup=trace_case("url"), targets=(TRACE_TARGET,)),
    Case("registry_yaml_syntax", ("registry.yaml", "not valid YAML"), setup=trace_case("registry_yaml"), targets=(TRACE_TARGET,)),
    Case("registry_bad_sha", ("registry.yaml", "sha256", "64 hex"), setup=trace_case("registry_sha"), targets=(TRACE_TARGET,)),
    # --- the RINEX navigation file, the IQ recording and its sidecar
    Case("rinex_missing", ("gps_jamming.ephemerides", "not found"), {"gps_jamming": {"ephemerides": "nosuch.15n"}}),
    Case("rinex_garbage", ("garbage.15n",), via="script", script="from scintrack.signals.gps import ephemeris\n"
         "p = {tmp!r} + '/garbage.15n'\nopen(p, 'w').write('this is not RINEX\\n' * 5)\nephemeris.load(p)\n"),
    Case("rinex_truncated", ("cut.15n",), via="script", script="from scintrack.signals.gps import ephemeris\n"
         f"raw = open({str(REPO / 'data' / 'ephemerides' / 'brdc2800.15n')!r}).read()\n"
         "p = {tmp!r} + '/cut.15n'\nopen(p, 'w').write(raw[: len(raw) // 2 + 37])\nephemeris.load(p)\n"),
    Case("iq_truncated", ("rec.bin",), via="script", script=iq_script("rec.write_bytes(rec.read_bytes()[:-3])")),
    Case("iq_sidecar_missing", ("rec.bin",), via="script", script=iq_script("iq.sidecar_path(rec).unlink()")),
    Case("iq_sidecar_corrupt", ("rec.bin",), via="script", script=iq_script("iq.sidecar_path(rec).write_text('{not json')")),
    # --- intermediate files, and writing outputs
    Case("netcdf_truncated_intermediate", ("s4-0.3.nc", "rerun"), setup=_corrupt_fit, targets=(BASE_TARGET,)),
    Case("disk_full", ("could not write", "free disk space"), setup=_disk_full, targets=(BASE_TARGET,), preexec=_file_limit),
    Case("read_only_folder", ("could not write", "writable"), setup=_read_only, targets=(BASE_TARGET,), preexec=_drop_dac),
]


# --- running a case ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    """A finished smoke workdir holding some outputs (the AR look-up table and its inputs)."""
    work = tmp_path_factory.mktemp("bad_input_base") / "work"
    proc = subprocess.run(_snakemake(work, BASE_TARGET), capture_output=True, text=True, timeout=600, env=snakemake_env())
    assert proc.returncode == 0, proc.stderr[-3000:]
    return work


def _snakemake(work: Path, *targets: str, overlays: tuple[str, ...] = (), extra: tuple[str, ...] = (), cores: str = "1",
               own_process: bool = False) -> list[str]:
    """The command of a case (``own_process``: the plain console script, for a case whose limits or
    capabilities, set before exec, must hold in Snakemake's own process; else through the warm server)."""
    dry = () if targets else ("-n",)
    return [*([SNAKEMAKE] if own_process else snakemake_cmd()), *targets, *dry, "-s", str(REPO / "Snakefile"), "--directory", str(work), "--cores", cores, *extra,
            "--configfile", str(REPO / "config" / "smoke.yaml"), *overlays]


def _snapshot(work: Path) -> dict[str, tuple[str, int]]:
    out = {}
    for root in ROOTS:
        for p in sorted((work / root).rglob("*")) if (work / root).exists() else []:
            if p.is_file():
                out[str(p.relative_to(work))] = (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns)
    return out


def _write_overlay(tmp: Path, overlay) -> Path:
    path = tmp / "overlay.yaml"
    path.write_text(overlay if isinstance(overlay, str) else yaml.safe_dump(overlay))
    return path


def _run(case: Case, base: Path, tmp: Path) -> tuple[subprocess.CompletedProcess, Path, dict, set[str]]:
    work = tmp / "work"
    shutil.copytree(base, work, symlinks=True)
    overlay = case.overlay
    touched: set[str] = set()
    if case.setup is not None:
        before_setup = _snapshot(work)
        added = case.setup(work, tmp)
        touched = {k for k, v in before_setup.items() if _snapshot(work).get(k) != v}
        if added:
            overlay = added
    before = {k: v for k, v in _snapshot(work).items() if k not in touched}
    env = snakemake_env(**case.env)
    overlays = (str(_write_overlay(tmp, overlay)),) if overlay is not None else ()
    if case.via == "snakemake":
        cmd = _snakemake(work, *case.targets, overlays=overlays, extra=case.extra, own_process=case.preexec is not None)
    elif case.via == "repro":
        cmd = [sys.executable, str(REPO / "repro.py"), "run", "-n", *case.extra, *(("--configfile", *overlays) if overlays else ())]
    elif case.via == "main_yaml":  # a copy of the repository whose config/config.yaml is broken
        repo = tmp / "repo"
        repo.mkdir()
        for part in ("Snakefile", "workflow", "config", "src"):
            if (REPO / part).is_dir():
                shutil.copytree(REPO / part, repo / part, ignore=shutil.ignore_patterns("__pycache__"))
            else:
                shutil.copy(REPO / part, repo / part)
        cfg = repo / "config" / "config.yaml"
        lines = cfg.read_text().splitlines()
        lines.insert(10, "tracking: {cn0_dbhz: [1")
        cfg.write_text("\n".join(lines) + "\n")
        cmd = [*snakemake_cmd(), "-n", "-s", str(repo / "Snakefile"), "--directory", str(work), "--cores", "1"]
    elif case.via == "reader":
        config = [str(REPO / "config" / "config.yaml"), str(REPO / "config" / "smoke.yaml"), *overlays]
        code = ("from scintrack import runlog\nrunlog.setup(None, 'case')\n"
                "from scintrack.config import load_config\nfrom scintrack.data.traces import load_trace\n"
                "from scintrack.pipeline.params import trace_input\n"
                f"run = trace_input(load_config({config!r}), 'event1')\n"
                "load_trace(run['source']['path'], list(run['bands']), float(run['ts']), event='event1', source='real')\n")
        cmd = [sys.executable, "-c", code]
    else:
        code = "from scintrack import runlog\nrunlog.setup(None, 'case')\n" + case.script.replace("{tmp!r}", repr(str(tmp)))
        cmd = [sys.executable, "-c", code]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env, cwd=tmp, preexec_fn=case.preexec)
    return proc, work, before, touched


@dataclass
class Outcome:
    proc: subprocess.CompletedProcess
    before: dict
    after: dict


def _outcome(case: Case, base: Path, tmp: Path) -> Outcome:
    tmp.mkdir(parents=True)
    proc, work, before, _ = _run(case, base, tmp)
    folder = work / "data" / "synthetic" / "csm_train_s4-0.5"
    if folder.exists():
        folder.chmod(0o755)  # (read_only_folder) let pytest clean up
    return Outcome(proc, before, _snapshot(work))


@pytest.fixture(scope="module")
def outcomes(base: Path, tmp_path_factory) -> dict[str, Outcome]:
    """Every case run once, as many at a time as this process has cores (each is a CPU-bound
    process): two alone on the 2-core machine, one under ``-n 2``, where the other worker's tests
    (the smoke DAG first) have the other core."""
    from concurrent.futures import ThreadPoolExecutor

    root = tmp_path_factory.mktemp("bad_input_cases")
    with ThreadPoolExecutor(max_workers=cores_per_worker()) as pool:
        futures = {c.name: pool.submit(_outcome, c, base, root / c.name) for c in CASES}
        return {name: f.result() for name, f in futures.items()}


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input_gives_one_clear_line(case: Case, outcomes: dict[str, Outcome]):
    result = outcomes[case.name]
    proc = result.proc
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0, out[-3000:]
    errors = [line for line in out.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1, f"expected one error line, got {len(errors)}:\n{out[-3000:]}"
    line = errors[0]
    for word in case.expect:
        assert word.lower() in line.lower(), f"{word!r} not in: {line}"
    assert "Traceback (most recent call last)" not in out, out[-3000:]
    assert not re.search(r'^\s*File ".*", line \d+', out, re.M), out[-3000:]
    assert "np.float64(" not in line and "\\n" not in line
    changed = [k for k, v in result.before.items() if result.after.get(k) != v]
    assert not changed, f"existing outputs changed or removed: {changed}"


def test_catalogue_size():
    assert len(CASES) >= 30
    assert len({c.name for c in CASES}) == len(CASES)
    json.dumps([c.name for c in CASES])
