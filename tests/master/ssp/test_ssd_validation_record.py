"""An SSD's validation against the SSP 1.0 schema is remembered across processes by the SHA-256 of the file's
bytes, fmpy's version (the schemas are its files) and libxml2's: the same bytes under the same schema are not
validated again (the schema, built anew in every process, is most of the cost); any other bytes or schema are."""
import fmpy
import pytest

from master.errors import ScenarioError
from master.ssp import xsd
from master.ssp.parser import read_ssd
from ssd_text import component, connector, ssd, write_folder

SSD = ssd("s", component("g", "resources/g.fmu", connector("u", "input")))     # read_ssd does not open the FMU


@pytest.fixture
def built(tmp_path, monkeypatch):
    """An empty cache folder, and the kinds whose schema validation asked for (each time it did)."""
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    asked = []
    schema = xsd._schema

    def noted(kind):
        asked.append(kind)
        return schema(kind)
    monkeypatch.setattr(xsd, "_schema", noted)
    return asked


@pytest.fixture
def place(tmp_path, test_fmus):
    def place(folder: str, ssd_xml: str = SSD):
        return write_folder(tmp_path / folder, ssd_xml, {"g.fmu": test_fmus["c2:Gain"]}) / "SystemStructure.ssd"
    return place


def _read(path):
    return read_ssd(path, path.parent)


def test_the_same_bytes_are_validated_once(built, place):
    path = place("a")
    assert _read(path).name == "s" and built == ["ssd"]
    other = place("b")     # the same bytes elsewhere: the same document
    assert _read(path).name == "s" and _read(other).name == "s" and built == ["ssd"]


def test_other_bytes_are_validated_again(built, place):
    """A file that changed after it passed is validated again and refused; without its bytes in the key it would
    be read as valid."""
    path = place("a")
    _read(path)
    path.write_text(SSD.replace('<ssd:System name="s">', '<ssd:System name="s" notInTheSchema="1">'))
    with pytest.raises(ScenarioError, match="does not conform to the SSP schema.*notInTheSchema"):
        _read(path)
    assert built == ["ssd", "ssd"]
    with pytest.raises(ScenarioError, match="notInTheSchema"):     # and a refused file is not remembered
        _read(path)


def test_another_schema_validates_again(built, place, monkeypatch):
    path = place("a")
    _read(path)
    monkeypatch.setattr(fmpy, "__version__", fmpy.__version__ + ".other")
    _read(path)
    assert built == ["ssd", "ssd"]


def test_an_unreadable_ssd_is_one_line(tmp_path, built):
    with pytest.raises(ScenarioError, match="cannot read"):
        _read(tmp_path / "missing" / "SystemStructure.ssd")
