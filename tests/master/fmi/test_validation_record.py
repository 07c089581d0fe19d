"""fmpy's validation of a modelDescription.xml (its schema, built anew in every process, and its own rules) is
remembered across processes by the SHA-256 of the description's bytes, fmpy's version and libxml2's: the same
bytes under the same validator are not validated again; any other bytes or validator are."""
import hashlib

import fmpy
import pytest
from lxml import etree

from master.errors import FmuError
from master.fmi import cache


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    """An empty FMU cache, no FMU read in this process yet, and the validate flag of every fmpy read noted."""
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(cache, "_by_stat", {})
    monkeypatch.setattr(cache, "_by_hash", {})
    calls = []
    read = fmpy.read_model_description

    def noted(*args, validate=True, **kwargs):
        calls.append(validate)
        return read(*args, validate=validate, **kwargs)
    monkeypatch.setattr(fmpy, "read_model_description", noted)

    def load(fmu):
        cache._by_stat.clear()          # as a new process: nothing read yet
        cache._by_hash.clear()
        calls.clear()
        return cache.load_fmu(fmu)
    return load, calls


def _names(md):
    return [(v.name, v.valueReference, v.causality, v.start) for v in md.modelVariables]


def test_the_same_bytes_are_validated_once(fresh, test_fmus, tmp_path):
    load, calls = fresh
    first = load(test_fmus["c2:Gain"])
    assert calls == [True]
    assert len(list((tmp_path / "cache" / "validated").iterdir())) == 1
    again = load(test_fmus["c2:Gain"])
    assert calls == [False]                 # read, not validated: these bytes passed this validator
    assert again.md is not first.md and _names(again.md) == _names(first.md)
    assert again.md.modelName == first.md.modelName and again.md.fmiVersion == first.md.fmiVersion


def test_other_bytes_are_validated_again(fresh, test_fmus):
    """A description that changed after it passed (here in the unpacked cache folder) is validated again and
    refused; without the bytes in the key it would be read as valid."""
    load, calls = fresh
    md_file = load(test_fmus["c2:Gain"]).unzip_dir / "modelDescription.xml"
    text = md_file.read_text()
    md_file.write_text(text.replace("<fmiModelDescription", "<fmiModelDescription notInTheSchema=\"1\"", 1))
    with pytest.raises(FmuError, match="invalid modelDescription.xml.*notInTheSchema"):
        load(test_fmus["c2:Gain"])
    assert calls == [True]


def test_another_validator_validates_again(fresh, test_fmus, monkeypatch):
    load, calls = fresh
    load(test_fmus["c2:Gain"])
    monkeypatch.setattr(fmpy, "__version__", fmpy.__version__ + ".other")
    load(test_fmus["c2:Gain"])
    assert calls == [True]


def test_another_libxml2_validates_again(fresh, test_fmus, monkeypatch):
    """libxml2 applies fmpy's schema, so its version is part of the validator too."""
    load, calls = fresh
    load(test_fmus["c2:Gain"])
    monkeypatch.setattr(etree, "LIBXML_VERSION", (0, 0, 1))
    load(test_fmus["c2:Gain"])
    assert calls == [True]


def test_the_record_keeps_its_name(fresh, test_fmus, tmp_path):
    """The record of an FMU description is named as before the validator's identity moved to
    ``cache_paths.fmpy_validator`` (a record written then still counts): the SHA-256 of each part with its length,
    the identity "fmpy <version> libxml2 <version>", then each validated file (present with its bytes, or
    missing). Computed here from that description, not through the code under test."""
    load, _ = fresh
    unzip_dir = load(test_fmus["c2:Gain"]).unzip_dir
    build_description = unzip_dir / "sources" / "buildDescription.xml"
    parts = [f"fmpy {fmpy.__version__} libxml2 {etree.LIBXML_VERSION}".encode(),
             b"present" + (unzip_dir / "modelDescription.xml").read_bytes(),
             b"present" + build_description.read_bytes() if build_description.is_file() else b"missing"]
    h = hashlib.sha256()
    for part in parts:
        h.update(b"%d:" % len(part) + part)
    assert [p.name for p in (tmp_path / "cache" / "validated").iterdir()] == [h.hexdigest()]


def test_a_cache_that_cannot_be_written_still_validates(fresh, test_fmus, tmp_path):
    load, calls = fresh
    load(test_fmus["c2:Gain"])
    record = next((tmp_path / "cache" / "validated").iterdir())
    record.unlink()
    record.mkdir()                          # not a file: no record, validated again (and not an error)
    load(test_fmus["c2:Gain"])
    assert calls == [True]
