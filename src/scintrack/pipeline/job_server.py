"""A warm job server for local runs: each job's Python script runs in a fork of one process that imported the libraries once.

Why: a job of this workflow pays ~1.5-2 CPU-s before it computes anything
(``import scipy.signal`` alone 0.7 s, xarray, netCDF4, numba's CPU target 0.5 s,
statsmodels, matplotlib), and a full run has ~270 jobs, most of which compute
for less than a second (``docs/performance.md``, tenth round).  A fork of a
process that has imported all of it starts in milliseconds, and the pages
it inherited are shared until written.

How: :func:`start` (the Snakefile's ``onstart``, local execution only, when
enough Python-script jobs are to run) launches ``python -m
scintrack.pipeline.job_server`` and waits until it has imported
:data:`PRELOAD` and the workflow scripts' own imports, and loaded the compiled
kernels that the numba cache already holds (:func:`load_cached_kernels`;
never a compilation).  The server listens on
a Unix socket (``$SCINTRACK_JOB_SERVER_ADDR``, inherited by the jobs).  Each
job process (:func:`.job_client.delegate`, the first line of every workflow
script) sends its argument vector, working directory, environment and its
three standard streams; the server forks; the child takes them over and runs
the job's script (Snakemake's temporary script, preamble included) exactly as
``python <script>`` would, then ends without the interpreter's teardown (as
:mod:`scintrack.fast_exit` does for every job).  The server reaps the child
and sends the job process its exit status; the job process exits the same
way.  :func:`stop` (``onsuccess``/``onerror``) ends it.

What makes it safe:

* The server never runs job code itself and stays single-threaded (checked
  through ``/proc/self/task`` before it serves: a fork copies one thread),
  with one-thread BLAS pools; every child starts from the same pristine
  state, so no job sees what another one did.
* A job runs in a fork only if the environment variables that libraries read
  at import (thread pools, allocator, numba settings, the numba cache
  folder, which follows the package's source, the hash seed) and the
  interpreter equal the server's; otherwise, or if the server cannot be
  reached, it runs in its own process as before.  A job with ``threads > 1``
  always runs in its own process.
* The child takes over the job's full environment, working directory and
  argument vector before the script runs.
* The server ends with Snakemake (it checks its parent every second; a
  Ctrl-C reaches it with the rest of the terminal's process group) and ends
  its children first; a child whose job process died (its connection
  closed) kills itself.
* Snakemake's ``benchmark:`` sampler (:mod:`.benchmark_sampling`) counts a
  job's child with the job's own process tree (through a pid file per job in
  the server's folder), so ``max_rss`` and ``cpu_time`` stay the job's.

``SCINTRACK_JOB_SERVER=0`` turns it off (each job then starts its own
interpreter, as Snakemake does by default); a cluster or any non-local
executor never uses it.

The test suite runs the ``snakemake`` command itself through a server of this
kind that has imported Snakemake only (:func:`launch` with ``preload``,
``env`` and ``forget``; ``tests/warm_snakemake.py``).
"""

from __future__ import annotations

import ast
import gc
import importlib
import os
import selectors
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from . import job_client

SWITCH_ENV = "SCINTRACK_JOB_SERVER"
#: Fewer Python-script jobs to run than this: no server (its start-up, ~3 CPU-s, would not pay).
MIN_JOBS = 6
#: Imported once by the server (the workflow scripts' own imports are added: :func:`script_imports`).
PRELOAD = (
    "numpy", "scipy.signal", "scipy.stats", "scipy.linalg", "scipy.ndimage", "scipy.integrate", "scipy.fft", "scipy.io",
    "pandas", "xarray", "netCDF4", "numba", "statsmodels.tsa.ar_model", "statsmodels.tsa.stattools",
    "matplotlib", "matplotlib.pyplot", "matplotlib.backends.backend_pdf", "snakemake.script", "snakemake.logging", "snakemake.iocontainers",
    # imported inside functions: the tracker registry's and the config's schema checks, every figure's PDF, every table's Markdown
    "jsonschema", "tabulate",
    "scintrack.figures.vila_valls_2018", "scintrack.figures.vila_valls_2018_aekf", "scintrack.figures.vila_valls_2018_traces",
    "scintrack.figures.susi_2014", "scintrack.figures.zhao_jamming", "scintrack.figures.zhao_receiver", "scintrack.figures.ranking",
    "scintrack.tables.vila_valls_2018", "scintrack.tables.vila_valls_2018_aekf", "scintrack.tables.vila_valls_2018_traces",
    "scintrack.tables.susi_2014", "scintrack.tables.zhao_jamming", "scintrack.tables.ranking",
)
PID_DIR = "jobs"  # <server folder>/jobs/<job pid>: the pid of the child running that job (for the benchmark sampler)


# --- the server process ----------------------------------------------------------------------


def script_imports(scripts_dir: Path) -> list[str]:
    """Modules imported at the top level of the workflow scripts (``workflow/scripts/*.py``)."""
    found: list[str] = []
    for path in sorted(scripts_dir.glob("*.py")):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Import):
                found += [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                found.append(node.module)
    return list(dict.fromkeys(found))


def _preload(modules: list[str]) -> list[str]:
    """Import ``modules`` (failures are reported, not fatal) and ready numba's CPU target; returns the failures."""
    failed = []
    for name in modules:
        try:
            importlib.import_module(name)
        except Exception as exc:  # noqa: BLE001 - a module that fails here fails in its job, with its own message
            failed.append(f"{name}: {type(exc).__name__}: {exc}")
    try:  # numba registers its typing and lowering tables on a target's first use (~0.5 s per process)
        from numba.core.registry import cpu_target

        cpu_target.typing_context.refresh()
        cpu_target.target_context.refresh()
    except Exception as exc:  # noqa: BLE001
        failed.append(f"numba target: {exc}")
    return failed


def load_cached_kernels(modules: list[str]) -> int:
    """Load every compiled kernel the numba cache already holds for the code as it is; returns how many.

    Scans the numba dispatchers (``@njit(cache=True)``) defined in ``modules`` and, when one of them is in
    the package, in every module of :mod:`scintrack` (kernels live in modules no script imports at their top
    level; importing the rest costs ~0.03 s).  Only index entries whose key matches the code as it is are
    loaded, so this never compiles: with an empty cache it loads nothing.  Each fork then calls the kernels
    without reading the cache (~3 ms per kernel and job).  Any numba internals this does not know: nothing
    is loaded and the jobs read the cache themselves, as without the server.

    The lazily built ufuncs of :mod:`scintrack.trackers.blocks` (``_Ufunc``) are built here too (counted
    in the number returned): their element kernels come from the cache (compiled once, here, when it is
    empty), but numba compiles a ufunc's loop wrapper in every process that builds it, ~60 ms each, which
    a job using one paid itself (42 builds in a full run, ~3 CPU-s; issue 14).
    """
    try:
        from numba.core.registry import CPUDispatcher
    except Exception:  # noqa: BLE001
        return 0
    names = set(modules)
    if any(m == "scintrack" or m.startswith("scintrack.") for m in modules):
        import pkgutil

        import scintrack

        for info in pkgutil.walk_packages(scintrack.__path__, "scintrack."):
            if info.name.endswith((".__main__", ".job_server")):
                continue
            try:
                importlib.import_module(info.name)
            except Exception:  # noqa: BLE001 - fails in its own job, with its own message
                continue
        names |= {name for name in sys.modules if name.startswith("scintrack.")}
    loaded, seen = 0, set()
    for name in sorted(names):
        for obj in list(getattr(sys.modules.get(name), "__dict__", {}).values()):
            if type(obj).__name__ == "_Ufunc" and id(obj) not in seen:
                seen.add(id(obj))  # a lazily built ufunc (trackers.blocks): its loop wrapper is compiled per process
                try:
                    obj.build()
                    loaded += 1
                except Exception:  # noqa: BLE001 - builds (and fails, with its message) in its own job
                    pass
                continue
            if not isinstance(obj, CPUDispatcher) or id(obj) in seen:
                continue
            seen.add(id(obj))
            try:
                cache, codegen = obj._cache, obj.targetctx.codegen()
                for key in cache._cache_file._load_index():
                    # an entry of this dispatcher (its keys are argument-type tuples; a ufunc's element kernel, keyed
                    # by a full signature, is not one of its overloads) for this code: compile() loads it
                    if isinstance(key[0], tuple) and key == cache._index_key(key[0], codegen):
                        obj.compile(key[0])
                        loaded += 1
            except Exception:  # noqa: BLE001 - no disk cache (cache=False), or internals this does not know
                continue
    return loaded


def _threads() -> int:
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return 1


class Server:
    """The accept/fork/reap loop (one thread)."""

    def __init__(self, folder: Path, parent: int, forget: tuple[str, ...] = ()):
        self.folder = folder
        self.parent = parent
        self.forget = forget  # packages each child drops from sys.modules before its script runs (:func:`forget_packages`)
        self.path = str(folder / "socket")
        self.children: dict[int, tuple[socket.socket, int]] = {}  # fork pid -> (its connection, its job's pid)
        self.stopping = False
        self.orphaned = False
        (folder / PID_DIR).mkdir(exist_ok=True)
        self.import_env = job_client.import_time_env(os.environ)
        self.interpreter = job_client.interpreter_id()

    def serve(self, ready_fd: int | None, preload_note: str) -> None:
        listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        tmp = self.path + ".tmp"
        listener.bind(tmp)
        listener.listen(64)
        os.rename(tmp, self.path)  # the socket appears only when the server can serve
        wake_r, wake_w = os.pipe()
        os.set_blocking(wake_w, False)
        os.set_blocking(wake_r, False)
        signal.set_wakeup_fd(wake_w)
        signal.signal(signal.SIGCHLD, lambda *_: None)
        for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
            signal.signal(sig, self._on_stop)
        self.listener, self.wake = listener, (wake_r, wake_w)
        gc.collect()
        gc.freeze()  # the children's collector never walks (and so never copies) the inherited objects
        if ready_fd is not None:
            os.write(ready_fd, f"ready {preload_note}\n".encode())
            os.close(ready_fd)
        sel = selectors.DefaultSelector()
        sel.register(listener, selectors.EVENT_READ, "accept")
        sel.register(wake_r, selectors.EVENT_READ, "wake")
        try:
            while not self.stopping:
                for key, _ in sel.select(timeout=1.0):
                    if key.data == "accept":
                        self._accept()
                    else:
                        try:
                            while os.read(wake_r, 512):
                                pass
                        except BlockingIOError:
                            pass
                self._reap()
                if os.getppid() != self.parent:
                    self.orphaned = True  # Snakemake is gone: nobody else will remove the folder
                    break
        finally:
            self._shutdown()
            if self.orphaned:
                import shutil

                shutil.rmtree(self.folder, ignore_errors=True)

    def _on_stop(self, *_):
        self.stopping = True

    def _accept(self) -> None:
        try:
            conn, _ = self.listener.accept()
        except OSError:
            return
        fds: list[int] = []
        try:
            conn.settimeout(10.0)
            request, fds = job_client.recv_message(conn, max_fds=3)
            reason = self._refusal(request, fds)
            if reason:
                job_client.send_message(conn, {"refused": reason})
                raise ConnectionAbortedError(reason)
            sys.stdout.flush()
            sys.stderr.flush()  # nothing buffered here is written again by the child
            pid = os.fork()
            if pid == 0:
                self._child(conn, request, fds)  # never returns
            job = int(request.get("client_pid", 0))
            self.children[pid] = (conn, job)
            # a plain temporary + rename, not scintrack.atomic: its test hook (SCINTRACK_HOLD_BEFORE_RENAME) would delay every job
            pid_file = self.folder / PID_DIR / str(job)
            pid_file.with_suffix(".tmp").write_text(str(pid))
            os.replace(pid_file.with_suffix(".tmp"), pid_file)
            job_client.send_message(conn, {"pid": pid})
        except (OSError, ValueError, ConnectionError) as exc:
            print(f"job server: request not served: {exc}", file=sys.stderr)
            conn.close()
        finally:
            for fd in fds:
                os.close(fd)

    def _refusal(self, request: dict, fds: list[int]) -> str:
        if len(fds) != 3:
            return "the three standard streams were not passed"
        if request.get("interpreter") != self.interpreter:
            return "another interpreter"
        if request.get("import_env") != self.import_env:
            diff = sorted(set(request.get("import_env", {}).items()) ^ set(self.import_env.items()))
            return f"import-time environment differs: {diff[:4]}"
        return ""

    def _child(self, conn: socket.socket, request: dict, fds: list[int]) -> None:
        """In the fork: become the job's process, run its script, exit with its status."""
        code = 1
        try:
            signal.set_wakeup_fd(-1)
            for sig in (signal.SIGCHLD, signal.SIGTERM, signal.SIGHUP):
                signal.signal(sig, signal.SIG_DFL)
            signal.signal(signal.SIGINT, signal.default_int_handler)  # Python's own default
            self.listener.close()
            for fd in self.wake:
                os.close(fd)
            for other, _ in self.children.values():
                other.close()
            for target, fd in zip((0, 1, 2), fds):
                os.dup2(fd, target)
            for fd in fds:
                os.close(fd)
            fds.clear()
            os.chdir(request["cwd"])
            os.environ.clear()
            os.environ.update(request["env"])
            sys.argv = list(request["argv"])
            job_client.IN_CHILD = True
            forget_packages(self.forget)
            _watch_job_process(conn)
            code = _run_script(sys.argv[0])
        except BaseException:  # noqa: BLE001 - the child must end here whatever happens
            try:
                import traceback

                traceback.print_exc()
            except BaseException:  # noqa: BLE001
                pass
        finally:
            _end_child(code)

    def _reap(self) -> None:
        while self.children:
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                return
            if pid == 0:
                return
            if pid not in self.children:
                continue
            conn, job = self.children.pop(pid)
            (self.folder / PID_DIR / str(job)).unlink(missing_ok=True)
            msg = {"code": os.waitstatus_to_exitcode(status)}
            if os.WIFSIGNALED(status):
                msg = {"signal": os.WTERMSIG(status), "code": 128 + os.WTERMSIG(status)}
            try:
                job_client.send_message(conn, msg)
            except OSError:
                pass
            conn.close()

    def _shutdown(self) -> None:
        for pid in list(self.children):
            try:
                os.kill(pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        end = time.monotonic() + 5.0
        while self.children and time.monotonic() < end:
            self._reap()
            time.sleep(0.05)
        for pid in list(self.children):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        try:
            os.unlink(self.path)
        except OSError:
            pass


def forget_packages(packages: tuple[str, ...]) -> None:
    """Drop ``packages`` and their submodules from ``sys.modules``, so that the script imports them afresh.

    For a server whose children run a program that puts its own copy of a
    package first on ``sys.path`` (the test suite's warm Snakemake server: a
    Snakefile imports ``scintrack`` from the ``src`` beside it, which may be an
    edited copy of the repository).  The server itself imported the package
    to run; its children must not reuse that copy.
    """
    for name in [m for m in sys.modules if any(m == p or m.startswith(p + ".") for p in packages)]:
        del sys.modules[name]


def _watch_job_process(conn: socket.socket) -> None:
    """Kill this child when its job process goes away (the connection closes)."""
    import threading

    def watch():
        try:
            conn.settimeout(None)
            while conn.recv(64):
                pass
        except OSError:
            pass
        os.kill(os.getpid(), signal.SIGKILL)

    threading.Thread(target=watch, daemon=True, name="job-process-watch").start()


def _run_script(path: str) -> int:
    """Run ``path`` as ``__main__`` like ``python path`` does; its exit code (uncaught exceptions through ``sys.excepthook``)."""
    import runpy

    sys.path[0] = os.path.dirname(os.path.abspath(path))
    try:
        runpy.run_path(path, run_name="__main__")
    except SystemExit as exc:
        if exc.code is None:
            return 0
        if isinstance(exc.code, int):
            return exc.code
        print(exc.code, file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        sys.excepthook(*sys.exc_info())
        return 128 + signal.SIGINT
    except BaseException:  # noqa: BLE001 - reported as Python would, then a failed exit
        sys.excepthook(*sys.exc_info())
        return 1
    return 0


def _end_child(code: int) -> None:
    """The interpreter's exit minus its teardown: atexit handlers (log files), flushed streams, then ``_exit``."""
    import atexit

    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:  # noqa: BLE001
                pass
        os._exit(code)


def main(argv: list[str] | None = None) -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--folder", required=True)
    ap.add_argument("--parent", type=int, required=True)
    ap.add_argument("--ready-fd", type=int)
    ap.add_argument("--scripts", required=True, help="the workflow's scripts folder (their imports are preloaded)")
    ap.add_argument("--preload", help="comma-separated modules to import instead of PRELOAD and the scripts' imports (tests)")
    ap.add_argument("--forget", default="", help="comma-separated packages each child drops from sys.modules (forget_packages)")
    args = ap.parse_args(argv)
    if os.getppid() != args.parent:
        return
    t0 = time.process_time()
    modules = args.preload.split(",") if args.preload is not None else [*PRELOAD, *script_imports(Path(args.scripts))]
    modules = [m for m in modules if m]
    failed = _preload(modules)
    for line in failed:
        print(f"job server: not preloaded: {line}", file=sys.stderr)
    kernels = load_cached_kernels(modules)
    n = _threads()
    if n != 1:
        msg = f"error {n} threads after the imports: forking would copy one of them; jobs run in their own processes"
        print(f"job server: {msg}", file=sys.stderr)
        if args.ready_fd is not None:
            os.write(args.ready_fd, (msg + "\n").encode())
        return
    Server(Path(args.folder), args.parent, tuple(p for p in args.forget.split(",") if p)).serve(args.ready_fd, f"{time.process_time() - t0:.2f} CPU-s of imports, {kernels} cached kernels loaded")


# --- the Snakemake side ----------------------------------------------------------------------

_RUNNING: dict[str, object] = {}


def wanted(workflow) -> bool:
    """Whether this Snakemake process should start a server: local execution, not switched off, enough script jobs."""
    if os.environ.get(SWITCH_ENV, "1").strip().lower() in ("0", "off", "no", "false"):
        return False
    try:
        if not workflow.local_exec or workflow.remote_exec or workflow.subprocess_exec:
            return False
        jobs = [j for j in workflow.dag.needrun_jobs() if str(getattr(j.rule, "script", "") or "").endswith(".py")]
    except Exception:  # noqa: BLE001 - an API this does not know: no server
        return False
    return len(jobs) >= MIN_JOBS


def start(workflow, scripts: str, timeout_s: float = 120.0) -> str | None:
    """Start the server for this run if :func:`wanted`; its address (also exported to the jobs), or None."""
    if _RUNNING or not wanted(workflow):
        return None
    launched = launch(scripts, timeout_s=timeout_s)
    if launched is None:
        return None
    proc, folder, addr = launched
    os.environ[job_client.ADDR_ENV] = addr
    _RUNNING.update(proc=proc, folder=folder, pythonpath=os.environ.get("PYTHONPATH"))
    os.environ["PYTHONPATH"] = os.pathsep.join([str(write_early_hook(folder)), *filter(None, [os.environ.get("PYTHONPATH")])])
    from . import benchmark_sampling

    benchmark_sampling.follow_forks(folder / PID_DIR)
    import atexit

    atexit.register(stop)
    return addr


EARLY_HOOK = """\
# Written by scintrack.pipeline.job_server for one run (removed with the server's folder): a Snakemake script
# job of this run is handed to the run's job server before Snakemake's preamble imports Snakemake (~60 ms).
import os as _os
import sys as _sys


def _scintrack_early():
    argv0 = _sys.argv[0] if _sys.argv else ""
    if "/.snakemake/scripts/" not in argv0.replace(_os.sep, "/") or _os.environ.get("OMP_NUM_THREADS", "1") != "1":
        return
    try:
        import importlib.util

        spec = importlib.util.spec_from_file_location("_scintrack_job_client", {client!r})  # the standard library only
        client = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(client)
    except Exception:  # noqa: BLE001 - the job goes the usual way (the script's own delegate())
        return
    try:
        client.delegate(1)  # exits with the job's status when a fork of the server ran it; returns when refused
    except BaseException as exc:  # noqa: BLE001 - after a hand-off: end here, never run the job a second time
        _sys.stderr.write(f"error: the job server's hand-over failed ({{type(exc).__name__}}: {{exc}}); run again\\n")
        _os._exit(1)


def _shadowed():  # the sitecustomize this one hides on sys.path, if there is one
    import importlib.machinery
    import importlib.util

    here = _os.path.dirname(_os.path.abspath(__file__))
    spec = importlib.machinery.PathFinder.find_spec("sitecustomize", [p for p in _sys.path if _os.path.abspath(p or ".") != here])
    if spec is not None and spec.loader is not None:
        spec.loader.exec_module(importlib.util.module_from_spec(spec))


_scintrack_early()
_shadowed()
"""


def write_early_hook(folder: Path) -> Path:
    """Write :data:`EARLY_HOOK` as ``<folder>/early/sitecustomize.py``; returns that directory (for ``PYTHONPATH``).

    Snakemake runs a ``script:`` job as ``python <its temporary script>``, whose preamble imports Snakemake to
    unpickle the job's ``snakemake`` object before the script's first line (:func:`.job_client.delegate`) can
    hand the job over: ~60 ms of CPU per job, ~15 CPU-s of a full run.  With this directory on the jobs'
    ``PYTHONPATH`` (:func:`start`), Python's start-up (``site``) hands a job to the server first: the same
    :func:`.job_client.delegate` (its file loaded alone: the standard library only), and the fork runs the
    whole temporary script, preamble included, exactly as before.  Only Snakemake's temporary scripts
    (``.snakemake/scripts/``) of one-thread jobs are handed over; anything else, or a refusal, goes on as
    without the hook.  A ``sitecustomize`` that this one hides on ``sys.path`` still runs.
    """
    early = folder / "early"
    early.mkdir(exist_ok=True)
    (early / "sitecustomize.py").write_text(EARLY_HOOK.format(client=str(Path(job_client.__file__).resolve())))
    return early


def launch(scripts: str, timeout_s: float = 120.0, preload: list[str] | None = None, env: dict[str, str] | None = None,
           forget: tuple[str, ...] = ()) -> tuple[subprocess.Popen, Path, str] | None:
    """Start a server (child of this process) and wait until it serves: ``(process, folder, address)``, or None if it failed.

    ``preload``: modules to import instead of :data:`PRELOAD` and the scripts' imports (the tests' servers).
    ``env``: the server's environment (default: this process's, with thread pools of one thread, as
    Snakemake sets them for a ``threads: 1`` job); only clients whose import-time variables equal it are
    served.  ``forget``: packages the children import afresh (:func:`forget_packages`).
    """
    folder = Path(tempfile.mkdtemp(prefix="scintrack-jobs-"))
    if env is None:
        env = {**os.environ, **dict.fromkeys(job_client.THREAD_POOL_VARS, "1")}
    read_fd, write_fd = os.pipe()
    log = open(folder / "server.log", "ab")
    proc = subprocess.Popen(
        [sys.executable, "-m", "scintrack.pipeline.job_server", "--folder", str(folder), "--parent", str(os.getpid()),
         "--ready-fd", str(write_fd), "--scripts", scripts, *(["--preload", ",".join(preload)] if preload is not None else []),
         *(["--forget", ",".join(forget)] if forget else [])],
        env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=log, pass_fds=(write_fd,), close_fds=True,
    )
    os.close(write_fd)
    log.close()
    line = _read_line(read_fd, timeout_s)
    os.close(read_fd)
    if not line.startswith("ready"):
        proc.kill()
        proc.wait()
        print(f"job server not started ({line or 'no answer'}; see {folder / 'server.log'}): every job starts its own interpreter",
              file=sys.stderr)
        return None
    return proc, folder, f"{socket.gethostname()}|{folder / 'socket'}"


def _read_line(fd: int, timeout_s: float) -> str:
    import select

    end = time.monotonic() + timeout_s
    buf = b""
    while b"\n" not in buf and time.monotonic() < end:
        ready, _, _ = select.select([fd], [], [], max(0.0, end - time.monotonic()))
        if not ready:
            break
        chunk = os.read(fd, 4096)
        if not chunk:
            break
        buf += chunk
    return buf.decode(errors="replace").strip()


def stop() -> None:
    """End the server of this run (its children first), remove its folder, the jobs' address and early hook."""
    proc = _RUNNING.pop("proc", None)
    folder = _RUNNING.pop("folder", None)
    os.environ.pop(job_client.ADDR_ENV, None)
    if "pythonpath" in _RUNNING:
        previous = _RUNNING.pop("pythonpath")
        if previous is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = previous
    if proc is None:
        return
    from . import benchmark_sampling

    benchmark_sampling.follow_forks(None)
    shutdown(proc, folder)


def shutdown(proc: subprocess.Popen, folder: Path) -> None:
    """Stop a server started by :func:`launch` and remove its folder."""
    proc.terminate()
    try:
        proc.wait(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    import shutil

    shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
