"""The warm job server (scintrack.pipeline.job_server / job_client): a job's script runs in a fork of the
server with the job's own streams, environment, working directory and arguments, its exit status comes
back, signals reach it, it dies with its job process, and a job the server cannot serve runs in its own
process.  A light server (numpy only) keeps these tests quick; the workflow's real server runs in the
smoke DAG, and the one-core build (tests/test_reproducibility.py) compares its results, made without the
server, with the smoke run's."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from conftest import REPO, snakemake_env

from scintrack.pipeline import benchmark_sampling, job_client, job_server

SCRIPT = textwrap.dedent(
    """
    import json, os, sys, time
    sys.path.insert(0, {src!r})
    from scintrack.pipeline.job_client import delegate
    delegate(int(os.environ.get("T_THREADS", "1")))
    mode = os.environ.get("T_MODE", "")
    if mode == "sleep":
        with open(os.environ["T_MARKER"] + ".tmp", "w") as f:
            f.write(str(os.getpid()))
        os.replace(os.environ["T_MARKER"] + ".tmp", os.environ["T_MARKER"])
        time.sleep(60)
    print(json.dumps({{"pid": os.getpid(), "ppid": os.getppid(), "cwd": os.getcwd(), "value": os.environ.get("T_VALUE"),
                      "argv": sys.argv[1:], "stdin": sys.stdin.read(), "numpy": "numpy" in sys.modules}}))
    if mode == "exit3":
        sys.exit(3)
    if mode == "raise":
        raise RuntimeError("boom in the job")
    if mode == "hook":  # as scintrack.errors.install_script_hook: an uncaught error becomes one line
        sys.excepthook = lambda t, v, tb: sys.stderr.write(f"error: {{v}}\\n")
        raise ValueError("one clear line")
    """
)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    launched = job_server.launch(str(REPO / "workflow" / "scripts"), preload=["numpy"])
    assert launched is not None, "the light job server did not start"
    proc, folder, addr = launched
    yield proc, folder, addr
    job_server.shutdown(proc, folder)


@pytest.fixture()
def script(tmp_path):
    path = tmp_path / "job.py"
    path.write_text(SCRIPT.format(src=str(REPO / "src")))
    return path


def _env(addr: str, **extra: str) -> dict[str, str]:
    env = dict(os.environ, **dict.fromkeys(job_client.THREAD_POOL_VARS, "1"), **extra)
    env[job_client.ADDR_ENV] = addr
    return env


def _start(script: Path, env: dict[str, str], cwd: Path, *args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, str(script), *args], env=env, cwd=cwd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _wait_gone(pid: int, timeout: float = 10.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if not _alive(pid):
            return True
        time.sleep(0.02)
    return False


def test_job_runs_in_a_fork_with_its_streams_environment_cwd_and_arguments(server, script, tmp_path):
    proc, _, addr = server
    work = tmp_path / "work"
    work.mkdir()
    job = _start(script, _env(addr, T_VALUE="from the job"), work, "a", "b c")
    out, err = job.communicate("on stdin", timeout=60)
    assert job.returncode == 0, err
    seen = json.loads(out)
    assert seen["pid"] != job.pid and seen["ppid"] == proc.pid, "the script did not run in a fork of the server"
    assert seen["numpy"], "the fork should have the server's imports"
    assert seen["cwd"] == str(work) and seen["value"] == "from the job" and seen["argv"] == ["a", "b c"]
    assert seen["stdin"] == "on stdin"


@pytest.mark.parametrize(("mode", "code", "text"), [("exit3", 3, ""), ("raise", 1, "RuntimeError: boom in the job"),
                                                  ("hook", 1, "error: one clear line\n")])
def test_exit_status_and_traceback_come_back(server, script, tmp_path, mode, code, text):
    _, _, addr = server
    job = _start(script, _env(addr, T_MODE=mode), tmp_path)
    out, err = job.communicate("", timeout=60)
    assert job.returncode == code, err
    assert json.loads(out)["pid"] != job.pid
    assert text in err
    if mode == "hook":
        assert err == text, "the script's own excepthook reports the error, nothing else"


@pytest.mark.parametrize("how", ["TERM", "KILL"])
def test_a_stopped_job_process_stops_its_fork(server, script, tmp_path, how):
    proc, folder, addr = server
    marker = tmp_path / "child.pid"
    job = _start(script, _env(addr, T_MODE="sleep", T_MARKER=str(marker)), tmp_path)
    end = time.monotonic() + 60
    while not marker.exists():
        assert job.poll() is None and time.monotonic() < end, job.stderr.read() if job.poll() is not None else "no fork started"
        time.sleep(0.02)
    child = int(marker.read_text())
    assert child != job.pid and _alive(child)
    # the benchmark sampler counts the fork with the job's process
    benchmark_sampling.follow_forks(folder / job_server.PID_DIR)
    try:
        import psutil

        pids = [p.pid for p in benchmark_sampling._with_forks([psutil.Process(job.pid)])]
    finally:
        benchmark_sampling.follow_forks(None)
    assert pids == [job.pid, child]
    job.send_signal(signal.SIGTERM if how == "TERM" else signal.SIGKILL)
    job.communicate(timeout=30)
    assert _wait_gone(child), f"the fork outlived its job process (SIG{how})"
    assert job.returncode == -(signal.SIGTERM if how == "TERM" else signal.SIGKILL)
    assert proc.poll() is None, "the server must keep serving"


@pytest.mark.parametrize("extra", [{"OMP_NUM_THREADS": "2"}, {"T_THREADS": "2"}, {job_client.ADDR_ENV: "otherhost|/nonexistent"}])
def test_what_the_server_cannot_serve_runs_in_its_own_process(server, script, tmp_path, extra):
    _, _, addr = server
    job = _start(script, {**_env(addr), **extra}, tmp_path)
    out, err = job.communicate("", timeout=60)
    assert job.returncode == 0, err
    assert json.loads(out)["pid"] == job.pid


def test_server_stops_its_running_forks(script, tmp_path):
    launched = job_server.launch(str(REPO / "workflow" / "scripts"), preload=[])
    assert launched is not None
    proc, folder, addr = launched
    marker = tmp_path / "child.pid"
    job = _start(script, _env(addr, T_MODE="sleep", T_MARKER=str(marker)), tmp_path)
    end = time.monotonic() + 60
    while not marker.exists():
        assert job.poll() is None and time.monotonic() < end
        time.sleep(0.02)
    child = int(marker.read_text())
    job_server.shutdown(proc, folder)
    assert _wait_gone(child)
    job.communicate(timeout=30)
    assert job.returncode != 0, "a job whose fork was stopped must fail"
    assert not folder.exists()


def test_script_imports_lists_the_workflow_scripts_modules():
    mods = job_server.script_imports(REPO / "workflow" / "scripts")
    assert "scintrack.experiments.shard_job" in mods and "scintrack.pipeline.job_client" in mods


def test_server_ends_and_cleans_up_when_snakemake_dies(tmp_path):
    """The server's parent (Snakemake) killed outright: the server stops within seconds and removes its folder."""
    parent = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(f"""
            import sys, time
            sys.path.insert(0, {str(REPO / "src")!r})
            from scintrack.pipeline import job_server
            proc, folder, addr = job_server.launch({str(REPO / "workflow" / "scripts")!r}, preload=[])
            print(proc.pid, folder, flush=True)
            time.sleep(120)
        """)],
        stdout=subprocess.PIPE, text=True)
    pid, folder = parent.stdout.readline().split()
    assert _alive(int(pid)) and Path(folder, "socket").exists()
    parent.kill()
    parent.wait()
    assert _wait_gone(int(pid)), "the server outlived its parent"
    end = time.monotonic() + 5
    while Path(folder).exists() and time.monotonic() < end:
        time.sleep(0.05)
    assert not Path(folder).exists()


def test_server_loads_the_cached_kernels_and_compiles_none(tmp_path, monkeypatch):
    """A kernel the numba cache holds is loaded once in the server, so a fork calls it without reading the cache;
    a kernel the cache does not hold is left alone (the server never compiles)."""
    (tmp_path / "kmod_cached.py").write_text("from numba import njit\n\n@njit(cache=True)\ndef twice(x):\n    return 2.0 * x\n")
    (tmp_path / "kmod_cold.py").write_text("from numba import njit\n\n@njit(cache=True)\ndef thrice(x):\n    return 3.0 * x\n")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    warm = subprocess.run([sys.executable, "-c", "import kmod_cached; kmod_cached.twice(1.0)"], env=dict(os.environ), capture_output=True,
                          text=True, timeout=120)
    assert warm.returncode == 0, warm.stderr
    monkeypatch.syspath_prepend(str(tmp_path))
    import kmod_cached

    assert job_server.load_cached_kernels(["kmod_cached"]) == 1  # in this process too: the index entry matches the code
    assert len(kmod_cached.twice.overloads) == 1
    launched = job_server.launch(str(REPO / "workflow" / "scripts"), preload=["kmod_cached", "kmod_cold"])
    assert launched is not None
    proc, folder, addr = launched
    try:
        job = tmp_path / "job.py"
        job.write_text(textwrap.dedent(f"""
            import json, os, sys
            sys.path.insert(0, {str(REPO / "src")!r})
            from scintrack.pipeline.job_client import delegate
            delegate(1)
            import kmod_cached, kmod_cold
            print(json.dumps({{"ppid": os.getppid(), "cached": len(kmod_cached.twice.overloads), "cold": len(kmod_cold.thrice.overloads)}}))
            """))
        out = subprocess.run([sys.executable, str(job)], env=_env(addr), cwd=tmp_path, capture_output=True, text=True, timeout=60)
        assert out.returncode == 0, out.stderr
        got = json.loads(out.stdout)
        assert got == {"ppid": proc.pid, "cached": 1, "cold": 0}
    finally:
        job_server.shutdown(proc, folder)


def test_a_functions_ufunc_form_has_its_own_cache_and_is_never_loaded_as_its_njit_overload(tmp_path):
    """Both compiled forms of one block in one numba cache, then the server's kernel loading and a call from Python.

    The njit and the vectorize form of ``_atan_variance`` used to share a cache index (numba names it after the
    function), with keys of the same argument types; ``load_cached_kernels`` loaded the ufunc's element kernel as
    an overload of the njit function and the call crashed the process (SIGSEGV).  Each form now has its own
    index, and the loader takes argument-tuple keys only.
    """
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(REPO / "src"), "OPENBLAS_NUM_THREADS": "1"}
    fill = "import numpy as np; from scintrack.trackers import blocks; blocks.atan_variance_ufunc(np.array([1e4]), np.array([0.01])); blocks.atan_variance(1e4, 0.01)"
    done = subprocess.run([sys.executable, "-c", fill], env=env, capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr
    use = textwrap.dedent("""
        import json, pickle, glob, numpy as np
        from scintrack.pipeline import job_server
        from scintrack.trackers import blocks
        loaded = job_server.load_cached_kernels(["scintrack.trackers.blocks"])
        keys = {}
        for idx in glob.glob(%r + "/**/blocks._atan_variance*.nbi", recursive=True):
            with open(idx, "rb") as f:
                pickle.load(f)
                keys[idx.rsplit("/", 1)[1]] = sorted(type(k[0]).__name__ for k in pickle.loads(f.read())[1])
        unbuilt = sorted(k for k, v in vars(blocks).items() if type(v).__name__ == "_Ufunc" and v._ufunc is None)
        print(json.dumps({"loaded": loaded, "unbuilt": unbuilt, "njit": float(blocks.atan_variance(1e4, 0.01)),
                          "ufunc": float(blocks.atan_variance_ufunc(np.array([1e4]), np.array([0.01]))[0]), "keys": keys}))
        """) % str(tmp_path / "cache")
    out = subprocess.run([sys.executable, "-c", use], env=env, capture_output=True, text=True, timeout=180)
    assert out.returncode == 0, (out.returncode, out.stderr[-2000:])  # -11: the element kernel called as the njit function
    got = json.loads(out.stdout)
    assert got["loaded"] >= 1 and got["njit"] == got["ufunc"] > 0
    assert got["unbuilt"] == []  # every lazily built ufunc is built before the server forks (its loop wrapper is per process)
    py = f"py{sys.version_info[0]}{sys.version_info[1]}"
    assert got["keys"] == {f"blocks._atan_variance-{blocks_line()}.{py}.nbi": ["tuple"],
                           f"blocks._atan_variance_ufunc-{blocks_line()}.{py}.nbi": ["Signature"]}, got["keys"]


def blocks_line() -> int:
    from scintrack.trackers import blocks

    return blocks.atan_variance.py_func.__code__.co_firstlineno


# --- the suite's warm Snakemake server (conftest.snakemake_cmd, tests/warm_snakemake.py) ------------------

PROBE = textwrap.dedent(
    """\
    #!{python}
    import json, os, sys
    print(json.dumps({{"ppid": os.getppid(), "argv": sys.argv[1:], "cwd": os.getcwd(), "value": os.environ.get("T_VALUE"),
                      "snakemake": "snakemake.cli" in sys.modules, "scintrack": sorted(m for m in sys.modules if m.startswith("scintrack")),
                      "client": [m for m in sys.modules if "job_client" in m]}}))
    sys.exit(int(os.environ.get("T_CODE", "0")))
    """
)


@pytest.mark.parametrize("hash_seed", ["0", "1"])
def test_warm_snakemake_command_runs_in_a_fork_or_as_itself(tmp_path, hash_seed):
    """The command the suite starts Snakemake with: a fork of the warm server (Snakemake preloaded, no
    scintrack module inherited, the client's arguments, cwd, environment and exit status) when the
    import-time environment matches the server's; the plain program, exec'd, when it does not."""
    from conftest import SNAKEMAKE_ENV, snakemake_cmd, warm_server_pid

    cmd = snakemake_cmd()
    server_pid = warm_server_pid()
    if server_pid is None:
        pytest.skip("no warm Snakemake server in this process (not under xdist, or SCINTRACK_TEST_WARM_SNAKEMAKE=0)")
    probe = tmp_path / "probe"
    probe.write_text(PROBE.format(python=sys.executable))
    probe.chmod(0o755)
    env = snakemake_env(T_VALUE="v", T_CODE="4")
    env["PYTHONHASHSEED"] = hash_seed
    out = subprocess.run([*cmd[:-1], str(probe), "x", "y z"], capture_output=True, text=True, timeout=60, env=env, cwd=tmp_path)
    assert out.returncode == 4, out.stderr
    seen = json.loads(out.stdout)
    assert (seen["argv"], seen["cwd"], seen["value"]) == (["x", "y z"], str(tmp_path), "v")
    assert seen["client"] == []  # the hand-over left nothing of itself in the program
    if hash_seed == SNAKEMAKE_ENV["PYTHONHASHSEED"]:
        assert seen["ppid"] == server_pid and seen["snakemake"] and seen["scintrack"] == []
    else:  # refused: the client became the program (its parent is this test process)
        assert seen["ppid"] == os.getpid() and not seen["snakemake"]


def test_early_hook_hands_snakemakes_temporary_scripts_over_before_their_first_line(server, tmp_path):
    """With the run's hook directory on PYTHONPATH (job_server.start), Python's start-up hands a script of
    ``.snakemake/scripts/`` to the server before the script's first line runs (Snakemake's preamble imports
    Snakemake there): the fork runs the whole script, its exit status comes back; any other script, or a job with
    more threads, runs as itself; a sitecustomize the hook hides on sys.path still runs."""
    proc, folder, addr = server
    hook = job_server.write_early_hook(folder)
    other = tmp_path / "other_site"
    other.mkdir()
    (other / "sitecustomize.py").write_text("import os\nos.environ['T_SHADOWED_RAN'] = '1'\n")
    body = textwrap.dedent("""
        import json, os, sys
        FIRST_LINE_PID = os.getpid()  # the process that runs the script's first line
        print(json.dumps({"pid": FIRST_LINE_PID, "ppid": os.getppid(), "numpy": "numpy" in sys.modules,
                          "shadowed": os.environ.get("T_SHADOWED_RAN"), "argv": sys.argv[1:]}))
        sys.exit(int(sys.argv[1]))
        """)
    scripts = tmp_path / ".snakemake" / "scripts"
    scripts.mkdir(parents=True)
    (scripts / "tmpabc.job.py").write_text(body)
    (tmp_path / "plain.py").write_text(body)
    pythonpath = os.pathsep.join([str(hook), str(other)])
    runs = {}
    for name, path, threads, code in (("snakemake", scripts / "tmpabc.job.py", "1", "0"), ("status", scripts / "tmpabc.job.py", "1", "4"),
                                      ("plain", tmp_path / "plain.py", "1", "0"), ("threads", scripts / "tmpabc.job.py", "2", "0")):
        env = {**_env(addr), "PYTHONPATH": pythonpath, **dict.fromkeys(job_client.THREAD_POOL_VARS, threads)}
        out = subprocess.run([sys.executable, str(path), code], env=env, cwd=tmp_path, capture_output=True, text=True, timeout=60)
        assert out.returncode == int(code), (name, out.stderr[-2000:])
        runs[name] = (json.loads(out.stdout), out)
    killed = scripts / "tmpdef.killed.py"  # killed (SIGKILL) in the fork: the job ends so, and never runs a second time
    killed.write_text(f"import os, signal\nif os.getppid() == {proc.pid}:\n    os.kill(os.getpid(), signal.SIGKILL)\nprint('ran again')\n")
    out = subprocess.run([sys.executable, str(killed)], env={**_env(addr), "PYTHONPATH": pythonpath}, cwd=tmp_path, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == -signal.SIGKILL and "ran again" not in out.stdout, (out.returncode, out.stdout, out.stderr[-2000:])
    seen = runs["snakemake"][0]
    assert seen["ppid"] == proc.pid and seen["numpy"] and seen["argv"] == ["0"], "the temporary script did not run in a fork"
    assert runs["status"][0]["ppid"] == proc.pid  # and its exit status (4) came back: checked above
    for name in ("plain", "threads"):
        assert runs[name][0]["ppid"] != proc.pid and not runs[name][0]["numpy"], name
        assert runs[name][0]["shadowed"] == "1", name  # the hidden sitecustomize ran in the job's own interpreter
