"""A damaged numba cache entry is found before numba loads it, compiled again, and named in one line.

The end-to-end tests run a throwaway module of tiny ``@njit(cache=True)``
kernels in fresh interpreters (the cache folder is chosen when
:mod:`scintrack` is imported, before numba is), with
``SCINTRACK_NUMBA_CACHE_ROOT`` in a temporary folder.  The tests of
:func:`scintrack.numba_cache.check` and :meth:`Workspace.publish` work on
synthetic files, without numba.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from scintrack import numba_cache
from scintrack.numba_cache import MANIFEST, MARK, check, entry_of

#: kernel name -> the damage done to its cache entry in the damaged-cache test ("ok": none)
DAMAGE = {
    "k_ok": "none",
    "k_trunc_nbi": "index cut to half its length",
    "k_trunc_nbc": "data file cut to half its length",
    "k_garble_nbi": "16 bytes in the middle of the index overwritten",
    "k_garble_nbc": "the first 16 bytes of the data file overwritten",
    "k_flip_a": "one bit flipped at 1/4 of the data file",
    "k_flip_b": "one bit flipped at 1/2 of the data file",
    "k_flip_c": "one bit flipped at 7/8 of the data file",
    "k_missing_nbc": "data file deleted",
    "k_extra": "an extra, unlisted data file",
}
KERNELS = list(DAMAGE)


def expected(name: str) -> float:
    i = KERNELS.index(name) + 1
    return 2.0 * i + i + 0.5


KERNEL_SOURCE = "from numba import njit\n" + "".join(
    f"\n\n@njit(cache=True)\ndef {name}(x):\n    return x * {i} + {i} + 0.5\n" for i, name in enumerate(KERNELS, start=1))

CHILD = """
import json, sys
from scintrack import numba_cache
space = numba_cache.configure()
import kernels
out = {"folder": str(space.folder)}
for name in sys.argv[1].split(","):
    f = getattr(kernels, name)
    out[name] = [f(2.0), sum(f.stats.cache_hits.values()), sum(f.stats.cache_misses.values())]
print(json.dumps(out))
"""


def child_env(root: Path, module_dir: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", MARK)}
    env["SCINTRACK_NUMBA_CACHE_ROOT"] = str(root)
    env["PYTHONPATH"] = os.pathsep.join([str(module_dir), *filter(None, [env.get("PYTHONPATH")])])
    return env


def start(root: Path, module_dir: Path, names: list[str], **kwargs) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", CHILD, ",".join(names)], env=child_env(root, module_dir), cwd=module_dir,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kwargs)


def finish(proc: subprocess.Popen) -> tuple[dict, str]:
    out, err = proc.communicate(timeout=180)
    assert proc.returncode == 0, err[-3000:]
    return json.loads(out.strip().splitlines()[-1]), err


def run(root: Path, module_dir: Path, names: list[str] = KERNELS) -> tuple[dict, str]:
    return finish(start(root, module_dir, names))


def the_folder(root: Path) -> Path:
    (folder,) = [p for p in root.iterdir() if p.is_dir()]
    return folder


def files_of(folder: Path, name: str) -> dict[str, Path]:
    return {rel: p for rel, p in numba_cache.cache_files(folder).items() if Path(rel).name.startswith(f"kernels.{name}-")}


@pytest.fixture(scope="module")
def module_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("kernels")
    (folder / "kernels.py").write_text(KERNEL_SOURCE)
    return folder


@pytest.fixture(scope="module")
def populated(module_dir, tmp_path_factory) -> Path:
    """A cache root filled by two processes at once, each compiling half the kernels into the same folder."""
    root = tmp_path_factory.mktemp("populated")
    half = len(KERNELS) // 2
    jobs = [start(root, module_dir, KERNELS[:half]), start(root, module_dir, KERNELS[half:])]
    for job, names in zip(jobs, (KERNELS[:half], KERNELS[half:])):
        out, err = finish(job)
        assert err == ""
        for name in names:
            assert out[name] == [expected(name), 0, 1]  # compiled, nothing was cached yet
    folder = the_folder(root)
    assert not [p for p in folder.iterdir() if p.name.startswith(numba_cache.WORK_PREFIX)]  # working folders removed
    return root


def copy_of(root: Path, tmp_path: Path) -> tuple[Path, Path]:
    new = tmp_path / "root"
    shutil.copytree(root, new)
    return new, the_folder(new)


def test_two_processes_keep_each_others_entries_and_an_intact_cache_is_loaded_without_a_warning(populated, module_dir, tmp_path):
    root, folder = copy_of(populated, tmp_path)
    before = {rel: p.read_bytes() for rel, p in numba_cache.cache_files(folder).items()}
    manifest = (folder / MANIFEST).read_bytes()
    assert {entry_of(rel) for rel in before} == {entry_of(rel) for rel in (folder / MANIFEST).read_text().split()[1::2]}
    assert len({entry_of(rel) for rel in before}) == len(KERNELS)

    out, err = run(root, module_dir)

    assert err == ""
    assert out["folder"] == str(folder), "the package source changed during the test"
    for name in KERNELS:
        assert out[name] == [expected(name), 1, 0], name  # loaded from the cache, not compiled
    assert {rel: p.read_bytes() for rel, p in numba_cache.cache_files(folder).items()} == before
    assert (folder / MANIFEST).read_bytes() == manifest


def damage(folder: Path) -> None:
    """Apply :data:`DAMAGE` to the cache entries in ``folder``."""
    for name in KERNELS:
        files = files_of(folder, name)
        index = next(p for rel, p in files.items() if rel.endswith(".nbi"))
        data = next(p for rel, p in files.items() if rel.endswith(".1.nbc"))
        blob = bytearray((index if name.endswith("nbi") else data).read_bytes())
        if name == "k_trunc_nbi":
            index.write_bytes(blob[: len(blob) // 2])
        elif name == "k_trunc_nbc":
            data.write_bytes(blob[: len(blob) // 2])
        elif name == "k_garble_nbi":
            mid = len(blob) // 2
            blob[mid:mid + 16] = bytes((b ^ 0xA5) for b in blob[mid:mid + 16])
            index.write_bytes(blob)
        elif name == "k_garble_nbc":
            blob[:16] = bytes((b ^ 0xA5) for b in blob[:16])
            data.write_bytes(blob)
        elif name.startswith("k_flip"):
            at = len(blob) * {"a": 2, "b": 4, "c": 7}[name[-1]] // 8
            blob[at] ^= 0x10
            data.write_bytes(blob)
        elif name == "k_missing_nbc":
            data.unlink()
        elif name == "k_extra":
            data.with_name(data.name.replace(".1.nbc", ".9.nbc")).write_bytes(blob)


def test_every_damaged_entry_is_compiled_again_with_one_warning_naming_the_folder(populated, module_dir, tmp_path):
    root, folder = copy_of(populated, tmp_path)
    damage(folder)

    out, err = run(root, module_dir)

    assert out["folder"] == str(folder), "the package source changed during the test"
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: ") and str(folder) in lines[0], err
    assert f"{len(KERNELS) - 1} kernel(s)" in lines[0]
    assert out["k_ok"] == [expected("k_ok"), 1, 0]  # the intact entry is still loaded
    for name in KERNELS[1:]:
        assert out[name] == [expected(name), 0, 1], (name, DAMAGE[name])  # compiled again, right value

    out, err = run(root, module_dir)  # the entries compiled again were saved and listed
    assert err == ""
    for name in KERNELS:
        assert out[name] == [expected(name), 1, 0], name
    assert not [rel for rel in files_of(folder, "k_extra") if rel.endswith(".9.nbc")]  # the unlisted file is gone


def _drop_dac() -> None:
    """As root, give up the capability that ignores file modes, so a read-only folder is read-only."""
    if os.geteuid() == 0:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_capbset_drop = 24
        for cap in (1, 2):  # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH
            libc.prctl(pr_capbset_drop, cap, 0, 0, 0)


def assert_one_error_line(proc: subprocess.CompletedProcess, folder: Path) -> None:
    assert proc.returncode == 1, proc
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert f"numba cache folder {folder} " in lines[0] and "delete it" in lines[0], lines[0]
    assert proc.stdout == ""


def test_a_read_only_folder_with_a_damaged_entry_gives_one_error_line_and_changes_nothing(populated, module_dir, tmp_path):
    root, folder = copy_of(populated, tmp_path)
    (victim,) = [p for rel, p in files_of(folder, "k_flip_a").items() if rel.endswith(".nbc")]
    blob = bytearray(victim.read_bytes())
    blob[len(blob) // 2] ^= 1
    victim.write_bytes(blob)
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    dirs = [folder, *(p for p in folder.rglob("*") if p.is_dir())]
    for d in dirs:
        d.chmod(0o555)
    try:
        proc = subprocess.run([sys.executable, "-c", CHILD, "k_ok"], env=child_env(root, module_dir), cwd=module_dir,
                              capture_output=True, text=True, timeout=120, preexec_fn=_drop_dac)
    finally:
        for d in dirs:
            d.chmod(0o755)
    assert_one_error_line(proc, folder)
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before


def test_a_cache_root_that_cannot_be_created_gives_one_error_line(module_dir, tmp_path):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the cache root should be\n")
    proc = subprocess.run([sys.executable, "-c", CHILD, "k_ok"], env=child_env(blocker / "numba", module_dir), cwd=module_dir,
                          capture_output=True, text=True, timeout=120)
    folder = blocker / "numba" / numba_cache.source_fingerprint()
    assert_one_error_line(proc, folder)


ENV_CHILD = """
import os
from scintrack import numba_cache
print(os.environ.get("NUMBA_CACHE_DIR", ""))
"""


def test_a_users_numba_cache_dir_is_left_alone_and_a_scintrack_parents_is_replaced(tmp_path):
    root = tmp_path / "root"
    base = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", MARK)}
    base["SCINTRACK_NUMBA_CACHE_ROOT"] = str(root)
    users = str(tmp_path / "mine")
    proc = subprocess.run([sys.executable, "-c", ENV_CHILD], env=dict(base, NUMBA_CACHE_DIR=users), capture_output=True,
                          text=True, timeout=60, check=True)
    assert proc.stdout.strip() == users and not root.exists()

    parents = str(tmp_path / "parent-work")  # the value a scintrack parent process exported
    proc = subprocess.run([sys.executable, "-c", ENV_CHILD], env=dict(base, NUMBA_CACHE_DIR=parents, **{MARK: parents}),
                          capture_output=True, text=True, timeout=60, check=True)
    work = Path(proc.stdout.strip())
    assert work.name.startswith(numba_cache.WORK_PREFIX) and work.parent.parent == root
    assert not work.exists()  # removed when the child ended


# --- check() and publish() on synthetic files (no numba) -------------------------------------------------------


def make_entry(folder: Path, name: str, data_files: int = 2) -> list[str]:
    sub = folder / "mod_0123"
    sub.mkdir(parents=True, exist_ok=True)
    rels = []
    for suffix in [".nbi", *(f".{n}.nbc" for n in range(1, data_files + 1))]:
        path = sub / f"m.{name}-1.py311{suffix}"
        path.write_bytes(os.urandom(300))
        rels.append(path.relative_to(folder).as_posix())
    return rels


def listed(folder: Path) -> dict[str, str]:
    return {rel: numba_cache.sha256_file(p) for rel, p in numba_cache.cache_files(folder).items()}


def test_check_deletes_a_damaged_entry_whole_and_keeps_the_others(tmp_path):
    folder = tmp_path / "cache"
    a, b = make_entry(folder, "a"), make_entry(folder, "b")
    numba_cache.write_manifest(folder, listed(folder))
    path = folder / a[2]
    blob = bytearray(path.read_bytes())
    blob[100] ^= 0x01
    path.write_bytes(blob)

    space = check(folder)

    assert sorted(numba_cache.cache_files(folder)) == sorted(b)
    assert numba_cache.read_manifest(folder) == (listed(folder), True)
    assert sorted(numba_cache.cache_files(space.work)) == sorted(b)  # only checked files are offered to numba
    assert all(os.path.samefile(space.work / rel, folder / rel) for rel in b)
    assert (space.removed, space.entries) == (3, 1) and str(folder) in space.warning()
    shutil.rmtree(space.work)


def test_an_unreadable_manifest_trusts_no_file(tmp_path):
    folder = tmp_path / "cache"
    make_entry(folder, "a")
    numba_cache.write_manifest(folder, listed(folder))
    (folder / MANIFEST).write_bytes(b"\xff\xfe garbled")
    space = check(folder)
    assert numba_cache.cache_files(folder) == {} and space.entries == 1
    assert numba_cache.read_manifest(folder) == ({}, True)
    shutil.rmtree(space.work)


def test_the_leftovers_of_a_dead_process_are_removed_and_a_live_ones_kept(tmp_path):
    folder = tmp_path / "cache"
    folder.mkdir()
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    host = numba_cache.host_name()
    dead = folder / f"{numba_cache.WORK_PREFIX}{host}-{gone.pid}.x1.scintrack-tmp"
    live = folder / f"{numba_cache.WORK_PREFIX}{host}-{os.getpid()}.x2.scintrack-tmp"
    for work in (dead, live):
        (work / "mod").mkdir(parents=True)
        (work / "mod" / "m.k-1.py311.nbi").write_bytes(b"unpublished")
    (folder / "mod").mkdir()
    killed = folder / "mod" / f".m.k-1.py311.nbi.{host}-{gone.pid}.x3.scintrack-tmp"  # a publication that was killed
    writing = folder / "mod" / f".m.k-1.py311.nbi.{host}-{os.getpid()}.x4.scintrack-tmp"  # one going on
    killed.write_bytes(b"half")
    writing.write_bytes(b"half")
    space = check(folder)
    assert not dead.exists() and live.exists()
    assert not killed.exists() and writing.exists()
    assert numba_cache.cache_files(folder) == {} and space.entries == 0  # work folders are not part of the cache
    shutil.rmtree(space.work)


def compile_into(space: numba_cache.Workspace, rel: str, payload: bytes) -> None:
    """What numba does when it saves: a temporary file, then a rename."""
    target = space.work / rel
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(target.name + ".tmp.0123")
    tmp.write_bytes(payload)
    os.replace(tmp, target)


def test_publications_merge_and_replace_an_entry_whole(tmp_path):
    folder = tmp_path / "cache"
    old = make_entry(folder, "k", data_files=3)
    numba_cache.write_manifest(folder, listed(folder))
    first, second = check(folder), check(folder)

    compile_into(first, old[0], b"new index of k")  # k recompiled: its index and first data file rewritten
    compile_into(first, old[1], b"new data of k")
    compile_into(second, "mod_0123/m.j-1.py311.nbi", b"index of j")  # a new kernel in the other process
    compile_into(second, "mod_0123/m.j-1.py311.1.nbc", b"data of j")

    assert second.publish() == 2
    assert first.publish() == 4  # the whole entry k (4 files), not only the two rewritten

    assert (folder / old[0]).read_bytes() == b"new index of k" and (folder / "mod_0123/m.j-1.py311.nbi").exists()
    sums, _ = numba_cache.read_manifest(folder)
    assert sums == listed(folder) and len(sums) == 6  # j's two files kept by k's publication
    again = check(folder)
    assert again.entries == 0 and again.warning() is None
    for space in (first, second, again):
        shutil.rmtree(space.work)


def test_a_process_that_compiled_nothing_publishes_nothing(tmp_path):
    folder = tmp_path / "cache"
    make_entry(folder, "k")
    numba_cache.write_manifest(folder, listed(folder))
    manifest = (folder / MANIFEST).read_bytes()
    space = check(folder)
    space.close()
    assert not space.work.exists() and (folder / MANIFEST).read_bytes() == manifest
