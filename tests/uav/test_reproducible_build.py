"""Building an FMU twice from the same sources gives the same bytes (fmu_sources/reproducible.py): a rebuild
that changes nothing must not change the shipped FMUs and SSPs, nor make campaign records stale."""
from __future__ import annotations

import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
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
