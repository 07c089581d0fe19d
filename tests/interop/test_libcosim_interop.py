"""Our SSPs run unchanged in libcosim (an independent master), and our Jacobi trajectories equal its own.

libcosim's fixed-step algorithm reads outputs right after each doStep and delivers them before the next
step, which is our Jacobi; its initialization iterates set/get/transfer as ours does for acyclic systems.
"""
import numpy as np
import pytest

import master
from master.ssp.writer import SspBuilder
from peers.libcosim_runner import run_libcosim


def _compare(ssp, step, stop, variables):
    ours = master.run(ssp, output=None, algorithm="jacobi", record=[f"{c}.{v}" for c, v in variables]).frame
    theirs = run_libcosim(ssp, step, stop, variables)
    assert len(ours) == len(theirs) == int(round(stop / step)) + 1
    np.testing.assert_allclose(ours["time"], theirs["time"], rtol=0, atol=1e-12)
    for c, v in variables:
        np.testing.assert_allclose(ours[f"{c}.{v}"], theirs[f"{c}.{v}"], rtol=0, atol=1e-12, err_msg=f"{c}.{v}")
    return ours


@pytest.mark.parametrize("family", ["c2", "py"])
def test_two_mass_oscillator_matches_libcosim(tmp_path, test_fmus, family):
    b = SspBuilder("osc", stop=5.0, step=0.05)
    b.add_component("A", test_fmus[f"{family}:MassA"], params={"x0": 1.0, "k": 2.0})
    b.add_component("B", test_fmus[f"{family}:MassB"], params={"kc": 0.5, "m": 2.0})
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    ours = _compare(b.write(tmp_path / "osc.ssp"), 0.05, 5.0, [("A", "x"), ("A", "v"), ("B", "x"), ("B", "F")])
    assert ours["B.x"].abs().max() > 0.1      # the coupling really moved the second mass


def test_feedback_chain_with_feedthrough_matches_libcosim(tmp_path, test_fmus):
    b = SspBuilder("chain", stop=2.0, step=0.01)
    b.add_component("I1", test_fmus["c2:Integrator"], params={"a": -0.3, "x0": 1.0})
    b.add_component("G", test_fmus["c2:Gain"], params={"k": -2.0})
    b.add_component("I2", test_fmus["c2:Integrator"], params={"a": 0.2, "x0": 0.5}, ssv=True)
    b.connect("I1", "y", "G", "u")
    b.connect("G", "y", "I2", "u")
    b.connect("I2", "y", "I1", "u")
    _compare(b.write(tmp_path / "chain.ssp"), 0.01, 2.0, [("I1", "y"), ("G", "y"), ("I2", "y")])
