"""Same sources, same FMU bytes: pythonfmu stamps every build with a time-based GUID, the build time and the zip
entries' mtimes, so each rebuild changed every shipped FMU and SSP (tens of MB of history per rebuild) and made
campaign records stale although nothing had changed. ``make_reproducible`` rewrites a built FMU with its entries
sorted, a fixed timestamp, no generation time and a GUID derived from the content."""
from __future__ import annotations

import hashlib
import os
import re
import uuid
import zipfile
from pathlib import Path

MODEL_DESCRIPTION = "modelDescription.xml"
# the zip format cannot store dates before 1980; any fixed date does
FIXED_TIME = (1980, 1, 1, 0, 0, 0)


def make_reproducible(fmu: Path | str, derive_guid: bool = True) -> Path:
    """``derive_guid=False`` keeps the GUID: a C FMU's binary checks the one compiled into it."""
    fmu = Path(fmu)
    with zipfile.ZipFile(fmu) as z:
        entries = {i.filename: (z.read(i.filename), i.external_attr) for i in z.infolist() if not i.is_dir()}
    if derive_guid:
        entries[MODEL_DESCRIPTION] = (_derived_guid(entries), entries[MODEL_DESCRIPTION][1])
    tmp = fmu.with_name(fmu.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for name in sorted(entries):
            data, attr = entries[name]
            info = zipfile.ZipInfo(name, date_time=FIXED_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = attr
            z.writestr(info, data)
    os.replace(tmp, fmu)
    return fmu


def _derived_guid(entries: dict) -> bytes:
    """modelDescription.xml without its generation time and with a GUID derived from the whole content."""
    text = entries[MODEL_DESCRIPTION][0].decode("utf-8")
    text = re.sub(r'\s+generationDateAndTime="[^"]*"', "", text, count=1)
    text = re.sub(r'guid="[^"]*"', 'guid=""', text, count=1)
    digest = hashlib.sha256(text.encode("utf-8"))
    for name in sorted(entries):
        if name != MODEL_DESCRIPTION:
            digest.update(name.encode("utf-8") + b"\0" + hashlib.sha256(entries[name][0]).digest())
    guid = uuid.uuid5(uuid.NAMESPACE_URL, "cosim-master:" + digest.hexdigest())
    return text.replace('guid=""', f'guid="{guid}"', 1).encode("utf-8")
