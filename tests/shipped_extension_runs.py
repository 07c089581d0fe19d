"""A shipped UAV scenario run in process twice: with the FMUs' own compiled extensions, then with their Python twins
(``COSIM_MASTER_PURE_PYTHON=1``).  Each extension's tests compare the two recordings."""
from __future__ import annotations

from pathlib import Path

import pytest

import master
from master.fmi.inprocess import PythonFmuSlave

SHIPPED = Path(__file__).resolve().parents[1] / "ssp" / "paper_zones_4uav_B.ssp"


def run_with_and_without_extensions(tmp_path, monkeypatch, classes: tuple, shells_expected: int, **kw):
    """(with, without) results of ``master.run(SHIPPED, **kw)``; skips where the shipped FMUs carry no extension for
    this platform, and checks that every stepped shell of ``classes`` used its extension in the first run."""
    shells = []
    orig = PythonFmuSlave.bound_cycle

    def spy(self, *a):
        shells.append(self.obj)
        return orig(self, *a)
    monkeypatch.setattr(PythonFmuSlave, "bound_cycle", spy)
    monkeypatch.delenv("COSIM_MASTER_PURE_PYTHON", raising=False)
    fast = master.run(SHIPPED, output=tmp_path / "ext", inprocess=True, **kw)
    stepped = list({id(s): s for s in shells if type(s).__name__ in classes}.values())
    assert len(stepped) == shells_expected
    if all(s._ext is None for s in stepped):
        pytest.skip("the shipped FMUs carry no extension for this platform")
    assert all(s._ext is not None for s in stepped)
    monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "1")
    pure = master.run(SHIPPED, output=tmp_path / "pure", inprocess=True, **kw)
    return fast, pure
