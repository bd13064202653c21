"""``verify`` on malformed bundles: every damage, unsafe member and unreadable part is one named line.

Each malformed bundle is made from a small well-formed one written by
:func:`scintrack.archive.tarball.write_tarball` (as the archive rule does),
then cut, bit-flipped or re-packed with one extra member.
"""

from __future__ import annotations

import gzip
import io
import json
import os
import subprocess
import sys
import tarfile

import numpy as np
import pytest

from scintrack.archive.tarball import SUMS, sums_text, write_tarball
from scintrack.archive.verify import verify

ROOT = "bundle-1"


def _nc_bytes(path) -> bytes:
    import netCDF4

    with netCDF4.Dataset(path, "w") as nc:
        nc.createDimension("t", 4)
        nc.createVariable("x", "f8", ("t",))[:] = np.arange(4.0)
        nc.setncattr("config_sha256", "0" * 64)
    return path.read_bytes()


def _members(nc: bytes | None = None) -> dict[str, bytes]:
    m = {"figures/a.png": b"\x89PNG fake" * 200, "tables/t.md": b"| a |\n|---|\n| 1 |\n"}
    if nc is not None:
        m["results/r.nc"] = nc
        m["results_manifest.json"] = json.dumps(
            {"content_sha256": {"results/r.nc": "1" * 64}, "config_sha256": {"results/r.nc": "0" * 64}, "included": ["results/r.nc"]}
        ).encode()
    m[SUMS] = sums_text(m).encode()
    return m


@pytest.fixture
def good(tmp_path):
    path = tmp_path / "good.tar.gz"
    write_tarball(_members(), path, root=ROOT)
    return path


def _write(path, data: bytes):
    path.write_bytes(data)
    return path


def _repack(good, path, extra=(), drop=()):
    """``good``'s members (less ``drop``), then ``extra`` (TarInfo, bytes or None), gzipped."""
    buf = io.BytesIO()
    with tarfile.open(good) as src, tarfile.open(fileobj=buf, mode="w", format=tarfile.GNU_FORMAT) as tar:
        for info in src.getmembers():
            if info.name not in drop:
                tar.addfile(info, src.extractfile(info))
        for info, data in extra:
            tar.addfile(info, None if data is None else io.BytesIO(data))
    return _write(path, gzip.compress(buf.getvalue(), mtime=0))


def _member(name, kind=tarfile.REGTYPE, data=b"", link="", mode=0o644):
    info = tarfile.TarInfo(name)
    info.type, info.linkname, info.mode = kind, link, mode
    info.size = len(data) if kind == tarfile.REGTYPE else 0
    return info, (data if kind == tarfile.REGTYPE else None)


def _cli(path):
    proc = subprocess.run([sys.executable, "-m", "scintrack", "verify", str(path)], capture_output=True, text=True, timeout=120)
    assert "Traceback" not in proc.stderr + proc.stdout, proc.stderr
    return proc


def test_well_formed_bundle_verifies_ok(good, tmp_path):
    assert verify(good) == []
    with_result = write_tarball(_members(_nc_bytes(tmp_path / "r.nc")), tmp_path / "nc.tar.gz", root=ROOT)
    assert with_result and verify(tmp_path / "nc.tar.gz") == []
    proc = _cli(good)
    assert proc.returncode == 0 and proc.stdout.startswith("OK ")


@pytest.mark.parametrize("cut", [1, 4, 8])
def test_archive_cut_short_in_its_gzip_trailer_is_damaged(good, tmp_path, cut):
    data = good.read_bytes()
    bad = _write(tmp_path / f"cut{cut}.tar.gz", data[:-cut])
    assert verify(bad) == [f"DAMAGED {bad} (compressed stream truncated: it ends before its end-of-stream marker; gzip -t rejects it)"]


def test_archive_cut_in_half_names_the_member_cut_short_and_the_ones_lost(good, tmp_path):
    data = good.read_bytes()
    bad = _write(tmp_path / "half.tar.gz", data[: len(data) // 2])
    proc = _cli(bad)
    lines = proc.stdout.splitlines()
    assert proc.returncode == 1 and lines, proc.stderr
    kind, name = lines[0].split()[:2]
    assert kind == "DAMAGED" and name in set(_members()) | {str(bad)}
    assert "truncated" in lines[0]
    assert all(line.split()[0] in {"DAMAGED", "MISSING"} for line in lines)


@pytest.mark.parametrize("offset, what", [(-8, "CRC check failed"), (-1, "Incorrect length"), (40, "compressed stream corrupt")])
def test_flipped_byte_in_the_gzip_stream_is_damaged(good, tmp_path, offset, what):
    data = bytearray(good.read_bytes())
    data[offset] ^= 0x01
    bad = _write(tmp_path / "flip.tar.gz", bytes(data))
    problems = verify(bad)
    assert any(line.startswith("DAMAGED ") and what in line for line in problems), problems
    assert all(line.split()[0] in {"DAMAGED", "MISSING"} for line in problems)


def test_crc_damage_fails_the_command_line_without_traceback(good, tmp_path):
    data = bytearray(good.read_bytes())
    data[-8] ^= 0xFF
    proc = _cli(_write(tmp_path / "crc.tar.gz", bytes(data)))
    assert proc.returncode == 1 and proc.stdout.startswith("DAMAGED ") and "crc.tar.gz" in proc.stdout
    assert "OK" not in proc.stdout


@pytest.mark.parametrize(
    "member, shown, reason",
    [
        (_member(f"{ROOT}/figures/evil.png", tarfile.SYMTYPE, link="/etc/passwd"), "figures/evil.png", "symbolic link to /etc/passwd"),
        (_member(f"{ROOT}/figures/evil.png", tarfile.LNKTYPE, link="/etc/passwd"), "figures/evil.png", "hard link to /etc/passwd"),
        (_member(f"{ROOT}/figures/pipe", tarfile.FIFOTYPE), "figures/pipe", "fifo"),
        (_member(f"{ROOT}/dev0", tarfile.CHRTYPE), "dev0", "character device"),
        (_member("/tmp/evil.txt", data=b"x"), "/tmp/evil.txt", "absolute path"),
        (_member(f"{ROOT}/../../evil.txt", data=b"x"), f"{ROOT}/../../evil.txt", "'..'"),
        (_member(f"{ROOT}/run.sh", data=b"#!/bin/sh\n", mode=0o4755), "run.sh", "mode 4755 sets setuid"),
    ],
    ids=["symlink", "hardlink", "fifo", "device", "absolute", "dotdot", "setuid"],
)
def test_links_special_files_and_escaping_paths_are_unsafe(good, tmp_path, member, shown, reason):
    bad = _repack(good, tmp_path / "unsafe.tar.gz", [member])
    problems = verify(bad)
    assert len(problems) == 1, problems
    assert problems[0].startswith(f"UNSAFE {shown} (") and reason in problems[0]


def test_symlink_member_fails_the_command_line(good, tmp_path):
    bad = _repack(good, tmp_path / "sym.tar.gz", [_member(f"{ROOT}/figures/evil.png", tarfile.SYMTYPE, link="/etc/passwd")])
    proc = _cli(bad)
    assert proc.returncode == 1 and proc.stdout.startswith("UNSAFE figures/evil.png (symbolic link to /etc/passwd")


def test_tampered_copy_under_a_second_root_folder_is_outside(good, tmp_path):
    bad = _repack(good, tmp_path / "two-roots.tar.gz", [_member("other/tables/t.md", data=b"| tampered |\n")])
    problems = verify(bad)
    assert len(problems) == 1 and problems[0].startswith(f"OUTSIDE other/tables/t.md (not under the bundle's root folder {ROOT}/"), problems
    proc = _cli(bad)
    assert proc.returncode == 1 and proc.stdout.startswith("OUTSIDE other/tables/t.md")


def test_duplicate_member_is_reported_and_the_copy_extraction_keeps_is_checked(good, tmp_path):
    bad = _repack(good, tmp_path / "dup.tar.gz", [_member(f"{ROOT}/tables/t.md", data=b"| tampered |\n")])
    problems = verify(bad)
    assert problems[0].startswith("DUPLICATE tables/t.md (2 members")
    assert problems[1].startswith("CHANGED tables/t.md") and len(problems) == 2
    same = _repack(good, tmp_path / "dup-same.tar.gz", [_member(f"{ROOT}/tables/t.md", data=_members()["tables/t.md"])])
    assert [line.split()[0] for line in verify(same)] == ["DUPLICATE"]


def test_tar_cut_short_inside_an_intact_gzip_names_the_member(good, tmp_path):
    with gzip.open(good) as gz:
        tar = gz.read()
    with tarfile.open(good) as src:
        png = src.getmember(f"{ROOT}/figures/a.png")
    bad = _write(tmp_path / "short-tar.tar.gz", gzip.compress(tar[: png.offset_data + 100]))
    assert verify(bad) == [f"DAMAGED figures/a.png (cut short in {bad}: the tar data end inside it)", "MISSING tables/t.md"]


def test_data_hidden_after_the_tar_end_is_damaged(good, tmp_path):
    bad = _write(tmp_path / "appended.tar.gz", good.read_bytes() * 2)  # a second archive, as a second gzip member
    problems = verify(bad)
    assert len(problems) == 1 and problems[0].startswith(f"DAMAGED {bad} (") and "end-of-archive" in problems[0]


@pytest.mark.parametrize("garbage", [b"\xff\xfe\x00binary", b"not a checksum line\n", b"abc123  tables/t.md\n"], ids=["binary", "text", "short-hash"])
def test_garbage_sums_is_malformed(good, tmp_path, garbage):
    bad = _repack(good, tmp_path / "sums.tar.gz", [_member(f"{ROOT}/{SUMS}", data=garbage)], drop=(f"{ROOT}/{SUMS}",))
    problems = verify(bad)
    assert len(problems) == 1 and problems[0].startswith(f"MALFORMED {SUMS} ("), problems


@pytest.mark.parametrize(
    "name, garbage, start",
    [
        ("results_manifest.json", b"{not json", "MALFORMED results_manifest.json (not JSON"),
        ("results_manifest.json", b'{"content_sha256": ["a"]}', "MALFORMED results_manifest.json (not a mapping"),
        ("config/config.yaml", b"a: [1", "MALFORMED config/config.yaml (not YAML"),
        ("config/config.yaml", b"a: 1\n", "MALFORMED config/config.yaml (it does not give the values"),
    ],
    ids=["manifest-json", "manifest-shape", "config-yaml", "config-keys"],
)
def test_garbage_manifest_or_config_is_malformed(tmp_path, name, garbage, start):
    members = _members(_nc_bytes(tmp_path / "r.nc"))
    members[name] = garbage
    members[SUMS] = sums_text(members).encode()
    write_tarball(members, tmp_path / "m.tar.gz", root=ROOT)
    problems = verify(tmp_path / "m.tar.gz")
    assert len(problems) == 1 and problems[0].startswith(start), problems


def test_damaged_result_header_is_reported_beside_a_changed_table(tmp_path):
    nc = bytearray(_nc_bytes(tmp_path / "r.nc"))
    nc[:8] = b"\x00" * 8  # the HDF5 signature
    members = _members(bytes(nc))
    members[SUMS] = sums_text(members).encode()  # the damaged file is the one listed
    members["tables/t.md"] = b"| tampered |\n"
    bad = tmp_path / "nc.tar.gz"
    write_tarball(members, bad, root=ROOT)
    problems = verify(bad)
    assert [line.split()[:2] for line in problems] == [["CHANGED", "tables/t.md"], ["RESULT-UNREADABLE", "results/r.nc"]], problems
    assert "bundle-member" not in "".join(problems)
    proc = _cli(bad)  # the netCDF library's reason may differ between processes: compare kind and member
    assert proc.returncode == 1 and [line.split()[:2] for line in proc.stdout.splitlines()] == [line.split()[:2] for line in problems]


def test_folder_bundle_with_symlink_and_fifo_is_unsafe(good, tmp_path):
    with tarfile.open(good) as tar:
        tar.extractall(tmp_path / "x", filter="data")
    root = tmp_path / "x" / ROOT
    assert verify(root) == []
    os.symlink("/etc/passwd", root / "figures" / "evil.png")
    os.mkfifo(root / "pipe")
    problems = verify(root)  # must not block on the fifo nor follow the link
    assert problems == [
        "UNSAFE pipe (a device, fifo or socket, not a regular file)",
        "UNSAFE figures/evil.png (symbolic link to /etc/passwd: a bundle holds only regular files)",
    ]
    proc = _cli(root)
    assert proc.returncode == 1 and proc.stdout.splitlines() == problems


def test_not_an_archive_is_unreadable_and_a_missing_path_is_one_error_line(tmp_path):
    bad = _write(tmp_path / "text.tar.gz", b"just text")
    assert verify(bad) == [f"UNREADABLE {bad} (not a gzip file: a bundle is the .tar.gz the archive rule writes, or its unpacked folder)"]
    no_tar = _write(tmp_path / "no-tar.tar.gz", gzip.compress(b"\x01" * 600))
    assert [line.split()[0] for line in verify(no_tar)] == ["UNREADABLE"]
    proc = _cli(tmp_path / "nope.tar.gz")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.startswith("error: ") and "nope.tar.gz" in proc.stderr and len(proc.stderr.splitlines()) == 1
