"""Validation records (``cache_paths.ValidationRecord``): one name per exact content, and a bounded folder."""
import os

from master import cache_paths
from master.cache_paths import ValidationRecord


def test_a_record_is_named_by_every_part_and_its_bounds(tmp_path, monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path))
    ValidationRecord(b"validator 1", b"<doc/>").remember()
    assert ValidationRecord(b"validator 1", b"<doc/>").passed()
    assert not ValidationRecord(b"validator 2", b"<doc/>").passed()
    assert not ValidationRecord(b"validator 1", b"<doc />").passed()
    assert not ValidationRecord(b"validator 1<doc/>").passed()          # the same bytes, cut elsewhere
    assert not ValidationRecord(b"validator ", b"1<doc/>").passed()


def test_the_oldest_half_goes_beyond_the_bound(tmp_path, monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path))
    monkeypatch.setattr(cache_paths, "MAX_VALIDATION_RECORDS", 4)
    records = [ValidationRecord(b"v", b"%d" % k) for k in range(5)]
    for age, record in enumerate(records[:4]):
        record.remember()
        os.utime(record.path, ns=(10**18 + age, 10**18 + age))        # made in this order, k = 0 oldest
    assert all(r.passed() for r in records[:4])
    records[4].remember()                                               # the fifth: over the bound
    assert [r.passed() for r in records] == [False, False, True, True, True]


def test_an_unwritable_cache_is_no_error(tmp_path, monkeypatch):
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "file"))   # a file where the folder would be
    ValidationRecord(b"v", b"x").remember()
    assert not ValidationRecord(b"v", b"x").passed()
