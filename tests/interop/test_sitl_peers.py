"""The shipped SITL missions (ssp/sitl_zones_*uav_B.ssp: ArduCopter SITL lock-stepped to our physics) in
OMSimulator, Ecos and libcosim, against cosim-master's jacobi, over their first 20 s (the firmware's start before
t = 0, arming, takeoff, the turn towards the first target).  Only where the SITL firmware is
($ARDUPILOT_SITL or ../shared/sitl/arducopter); each run starts one SITL process per UAV (about 15 s of wall time
for one UAV, 50 s for four, so the four-UAV SSP runs only with COSIM_INTEROP_SITL_4UAV=1).

Lock-step makes the firmware a deterministic function of the physics it is fed, so a peer that passes the same
inputs gets the same flight: Ecos and libcosim to rounding (ATOL 1e-9).  OMSimulator drops String parameters
(tests/interop/test_uav_peers.py), and here they carry the firmware parameters (``params``: WPNAV_SPEED and
WPNAV_ACCEL), so it is run with them set after instantiation and then agrees to rounding as well.

Ecos 0.7.2 segfaulted in its first step here (issue 26): it names every instance by the path of the unpacked FMU,
which our SITL FMU took as its working folder (the FMU file itself), so SITL did not start and
exitInitializationMode returned fmi2Fatal; Ecos stepped on regardless (FMI 2.0 allows no further call after
fmi2Fatal) and pythonfmu, which had released its Python objects on the exception, crashed in fmi2GetInteger.
The FMU now gives such an instance a folder of its own (tests/fmu_sources/sitlsim/test_sitl_instance_folder.py).
"""
from __future__ import annotations

import os

import numpy as np
import pytest
from peer_runs import SSP_DIR, Job, absent, sitl_binary

import master

STOP, STEP = 20.0, 0.1
N = int(round(STOP / STEP))
ATOL = 1e-9
PER_UAV = [("dyn", "x", "Real"), ("dyn", "y", "Real"), ("dyn", "z", "Real"), ("dyn", "phase", "Integer"),
           ("strat", "cmd", "Integer"), ("strat", "mission_state", "Integer"), ("strat", "current_target", "Integer")]
SSPS = ["sitl_zones_1uav_B"] + (["sitl_zones_4uav_B"] if os.environ.get("COSIM_INTEROP_SITL_4UAV") else [])

pytestmark = pytest.mark.skipif(sitl_binary() is None, reason="no ArduPilot SITL ($ARDUPILOT_SITL or "
                                                              "../shared/sitl/arducopter)")


def _variables(name):
    return [[f"uav{k}_{c}", v, t] for k in range(1, (4 if "4uav" in name else 1) + 1) for c, v, t in PER_UAV]


@pytest.fixture(scope="module")
def ours(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ARDUPILOT_SITL", os.environ.get("ARDUPILOT_SITL") or sitl_binary())
        return {n: master.run(SSP_DIR / f"{n}.ssp", output=tmp_path_factory.mktemp(n), algorithm="jacobi",
                              step=STEP, stop_time=STOP, record_interval=STEP, progress=False,
                              record=[f"{c}.{v}" for c, v, _ in _variables(n)]).frame for n in SSPS}


def uav_peer_jobs(peer, tmp_path_factory) -> dict:
    """This module's flights in ``peer`` ({name: Job}), run in the session's child of that peer with the other UAV
    interop modules' (conftest.py): one child start and one import of the peer and pandas fewer per peer."""
    if sitl_binary() is None:
        return {}
    return {n: Job(str(SSP_DIR / f"{n}.ssp"), STEP, N, _variables(n), set_strings=peer == "omsimulator")
            for n in SSPS}


@pytest.mark.parametrize("peer", ["omsimulator", "ecos", "libcosim"])
def test_sitl_mission_in_peer(peer, ours, request, uav_peer_runs, record_property):
    why = absent(peer)
    if why:
        pytest.skip(why)
    runs = uav_peer_runs(peer, request.module)
    for name in SSPS:
        theirs = runs[name]
        mine = ours[name]
        assert len(theirs) == len(mine) == N + 1
        np.testing.assert_allclose(theirs["time"], mine["time"], rtol=0, atol=1e-9)
        worst = 0.0
        for c, v, t in _variables(name):
            key = f"{c}.{v}"
            a, b = mine[key].to_numpy(), theirs[key].to_numpy()
            if t == "Integer":
                assert np.array_equal(a.astype(int), b.astype(int)), key
            else:
                np.testing.assert_allclose(b, a, rtol=0, atol=ATOL, err_msg=key)
                worst = max(worst, float(np.max(np.abs(a - b))))
        # the window saw the vehicle climb (the firmware armed and took off in the peer too)
        assert theirs["uav1_dyn.z"].max() > 5.0
        record_property(f"{name}_max_abs_diff", worst)
