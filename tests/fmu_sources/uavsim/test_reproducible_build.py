"""Building an FMU twice from the same sources gives the same bytes (fmu_sources/reproducible.py): a rebuild
that changes nothing must not change the shipped FMUs and SSPs, nor make campaign records stale."""
from __future__ import annotations

import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "fmu_sources"))

from build_fmus import build_fmu  # noqa: E402


def test_two_builds_are_byte_identical_and_keep_a_valid_guid(tmp_path):
    a = build_fmu("UavWind", tmp_path / "a").read_bytes()
    b = build_fmu("UavWind", tmp_path / "b").read_bytes()
    assert a == b
    with zipfile.ZipFile(tmp_path / "a" / "UavWind.fmu") as z:
        md = z.read("modelDescription.xml").decode()
        assert all(i.date_time == (1980, 1, 1, 0, 0, 0) for i in z.infolist())
    import re
    import uuid
    guid = re.search(r'guid="([^"]+)"', md).group(1)
    assert uuid.UUID(guid).version == 5 and "generationDateAndTime" not in md


def test_c_coupling_fmus_are_byte_identical_wherever_their_sources_are(tmp_path):
    """The C benchmark FMUs of ssp/coupling: the same sources compiled from another folder (a clone, a worktree)
    give the same bytes, and the GUID compiled into the binary stays the one in modelDescription.xml."""
    import os
    import shutil

    sys.path.insert(0, str(ROOT / "tests"))
    sys.path.insert(0, str(ROOT))
    from fmu_sources.coupling.build import build_c

    a = build_c(tmp_path / "a")["MassA"]
    # the framework and model sources copied elsewhere: paths differ, contents do not
    import fmu_factory as ff
    moved = tmp_path / "moved_sources"
    shutil.copytree(ff.C_DIR, moved)
    for f in moved.rglob("*"):          # a fresh checkout: other file times
        os.utime(f, (f.stat().st_atime, f.stat().st_mtime + 86400))
    original = ff.C_DIR
    ff.C_DIR = moved
    try:
        b = build_c(tmp_path / "b")["MassA"]
    finally:
        ff.C_DIR = original
    assert a.read_bytes() == b.read_bytes()
    with zipfile.ZipFile(a) as z:
        md = z.read("modelDescription.xml").decode()
        binary = z.read("binaries/linux64/MassA.so")
    import re
    assert re.search(r'guid="([^"]+)"', md).group(1).encode() in binary
