"""The SITL FMU's working folder when the master names the instance with something that is no folder name.

FMI gives instanceName no form; Ecos 0.7.2 passes the path of the unpacked FMU (measured:
"/tmp/ecos_ssp_<uuid>/resources/UavSitl.fmu").  The shell joined it to ``$COSIM_MASTER_OUTPUT/sitl``, and
``os.path.join`` with an absolute path is that path: the folder to create was the FMU file itself, SITL did
not start ("[Errno 17] File exists"), exitInitializationMode returned fmi2Fatal, and Ecos, stepping on after
it, crashed in pythonfmu (the segfault in its first step, issue 26).
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

SRC = Path(__file__).resolve().parents[3] / "fmu_sources"


def _shell(name: str):
    spec = importlib.util.spec_from_file_location("shell_UavSitl_folder", SRC / "UavSitl.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.UavSitl(instance_name=name, resources=str(SRC), visible=False)


def test_a_plain_instance_name_is_its_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_OUTPUT", str(tmp_path))
    assert _shell("uav1_dyn")._workdir() == str(tmp_path / "sitl" / "uav1_dyn")


def test_an_instance_named_by_a_path_gets_a_folder_of_its_own(tmp_path, monkeypatch):
    out = tmp_path / "out"
    monkeypatch.setenv("COSIM_MASTER_OUTPUT", str(out))
    fmu = tmp_path / "ecos_ssp" / "resources" / "UavSitl.fmu"
    fmu.parent.mkdir(parents=True)
    fmu.write_bytes(b"PK")                      # the unpacked FMU Ecos names its instances by
    first, second = _shell(str(fmu))._workdir(), _shell(str(fmu))._workdir()
    for folder in (first, second):
        assert Path(folder).is_dir() and Path(folder).parent == out / "sitl"
        assert Path(folder).name.startswith("UavSitl.fmu-")
    assert first != second                      # two instances of one FMU file: two SITL folders
    assert fmu.read_bytes() == b"PK"
