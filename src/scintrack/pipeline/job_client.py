"""The job side of the warm job server (:mod:`.job_server`): hand this script to a fork of it.

Every workflow script calls :func:`delegate` before it imports anything heavy.
When the Snakemake run started a job server (``$SCINTRACK_JOB_SERVER_ADDR``,
set by :func:`.job_server.start`), the job's process sends the server its
script, argument vector, working directory, environment and standard
streams; the server forks a child that has already imported numpy, scipy,
xarray, numba, statsmodels and matplotlib, the child runs the same script
(Snakemake's temporary script with its preamble) and this process waits for
it and exits with its status.  Otherwise, or if anything before the fork
fails, :func:`delegate` returns and the script runs here as before.

The child runs the same code on the same inputs with the same environment
variables, so results are the same bits either way
(``tests/test_job_server.py``).  Signals this process gets (SIGTERM, SIGINT,
SIGHUP, SIGQUIT: Snakemake stopping a job) are passed on to the child; if
this process dies without one (SIGKILL), the child notices the closed
connection and kills itself.

Only the standard library is imported here: the point is to start nothing.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import struct
import sys

ADDR_ENV = "SCINTRACK_JOB_SERVER_ADDR"
#: Environment variables read when a library is imported (thread pools, allocator, numba's
#: settings, hash seed): a job may run in a fork of the server only if its values equal the server's.
#: The thread pools Snakemake sizes from a job's ``threads`` (``snakemake.shell``).
THREAD_POOL_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "GOTO_NUM_THREADS", "VECLIB_MAXIMUM_THREADS",
                    "NUMEXPR_NUM_THREADS")
IMPORT_TIME_PREFIXES = ("NUMBA_", "SCINTRACK_NUMBA_")
IMPORT_TIME_VARS = (*THREAD_POOL_VARS, "GLIBC_TUNABLES", "PYTHONHASHSEED", "MPLBACKEND", "PYTHONOPTIMIZE")

#: True in a child of the server (set by the server before it runs the script): never delegate again.
IN_CHILD = False


def import_time_env(env: dict[str, str] | os._Environ) -> dict[str, str]:
    """The part of ``env`` that libraries read when they are imported (see ``IMPORT_TIME_VARS``)."""
    return {k: v for k, v in env.items() if k in IMPORT_TIME_VARS or k.startswith(IMPORT_TIME_PREFIXES)}


def interpreter_id() -> str:
    """Which interpreter this is: a child of a server started by another one cannot run this script."""
    return f"{sys.executable}|{sys.version}"


def send_message(sock: socket.socket, obj: dict, fds: list[int] | None = None) -> None:
    data = json.dumps(obj).encode()
    head = struct.pack("!I", len(data))
    if fds:
        socket.send_fds(sock, [head], fds)
    else:
        sock.sendall(head)
    sock.sendall(data)


def _recv_exact(sock: socket.socket, n: int) -> bytes:
    buf = b""
    while len(buf) < n:
        chunk = sock.recv(n - len(buf))
        if not chunk:
            raise ConnectionError("connection closed")
        buf += chunk
    return buf


def recv_message(sock: socket.socket, max_fds: int = 0) -> tuple[dict, list[int]]:
    """One length-prefixed JSON message (and up to ``max_fds`` file descriptors sent with its header)."""
    if max_fds:
        head, fds, _flags, _addr = socket.recv_fds(sock, 4, max_fds)
        if len(head) < 4:
            head += _recv_exact(sock, 4 - len(head))
    else:
        head, fds = _recv_exact(sock, 4), []
    (n,) = struct.unpack("!I", head)
    return json.loads(_recv_exact(sock, n)), list(fds)


def _exit_like(status: dict) -> None:
    """End this process the way the child ended."""
    sys.stdout.flush()
    sys.stderr.flush()
    sig = status.get("signal")
    if sig:
        if sig not in (signal.SIGKILL, signal.SIGSTOP):  # those two cannot be caught, nor their handler set
            signal.signal(sig, signal.SIG_DFL)
        os.kill(os.getpid(), sig)
    os._exit(int(status.get("code", 1)))


def delegate(threads: int = 1, addr: str | None = None) -> None:
    """Run this script in a fork of the run's job server and exit with its status; return if there is none.

    ``threads``: the job's ``threads`` (a job with more than one keeps its own
    process: the server's thread pools are sized for one).  ``addr``: the
    server's address (default ``$SCINTRACK_JOB_SERVER_ADDR``; the test suite's
    warm Snakemake server passes its own, so that the variable never reaches
    the workflow it runs).
    """
    addr = os.environ.get(ADDR_ENV) if addr is None else addr
    if IN_CHILD or not addr or int(threads) != 1:
        return
    host, _, path = addr.partition("|")
    if host != socket.gethostname() or not os.path.exists(path):
        return  # another machine (a cluster job that inherited the variable): run here
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.settimeout(30.0)
        sock.connect(path)
        request = {"argv": sys.argv, "cwd": os.getcwd(), "env": dict(os.environ), "interpreter": interpreter_id(),
                   "import_env": import_time_env(os.environ), "client_pid": os.getpid()}
        send_message(sock, request, [0, 1, 2])
        reply, _ = recv_message(sock)
    except (OSError, ValueError, ConnectionError):
        sock.close()
        return  # no fork happened: run here
    if reply.get("refused"):
        sock.close()
        return
    child = int(reply["pid"])

    def forward(signum, _frame):
        try:
            os.kill(child, signum)
        except ProcessLookupError:
            pass

    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGQUIT):
        signal.signal(sig, forward)
    sock.settimeout(None)
    try:
        status, _ = recv_message(sock)
    except (OSError, ValueError, ConnectionError):
        # the server went away with the child still running: stop it, report a failed job
        forward(signal.SIGKILL, None)
        print(f"error: the job server stopped while it ran this job (pid {child}); run again", file=sys.stderr)
        status = {"code": 1}
    _exit_like(status)
