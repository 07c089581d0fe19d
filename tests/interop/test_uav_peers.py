"""Every shipped UAV SSP (ssp/paper_*.ssp) in OMSimulator, Ecos and libcosim, against cosim-master's jacobi.

Each SSP is given to each peer unchanged (one child process per peer, tests/interop/peer_runs.py) and run for its
first 20 s at its 0.1 s step: preflight (5 s), takeoff to 20 m (to t = 16 s), the start of the first legs to the
targets (strategies A and B part here: A flies to its first target in the defined order, B to the nearest; every
UAV has its first target from t = 16 s) and, with zones, the detours around them (from t = 16.1 s); the four UAVs
of strategy A collide at t = 18.47 s.  No photo is taken before t = 30 s: a longer window adds more of the same
legs, at the peers' cost per step (they step the pythonfmu FMUs: most of this test's CPU).  Compared at every
communication point: every UAV's x, y, z and state of charge (reals) and its commands, phase, mission state,
current target and photo count (integers, exactly).  Agreement per peer (docs/interoperability.md):

* Ecos: bit-identical (its clock is a sum, t_{n+1} = t_n + h, but it passes h itself to doStep and nothing in these
  scenarios reads t: no wind), but for the last step to the stop time, which cosim-master shortens or lengthens by
  an ulp so that it ends exactly there (docs/ssp.md): that row agrees to rounding.
* libcosim: to rounding (its step sizes differ from h by ulps: tests/peers/libcosim_runner.py), ATOL 1e-9.
* OMSimulator (``oms_ma``): to rounding where the SSP's String parameters equal the FMU's defaults (strategy A,
  assignment "equal"): its clock is a sum and it passes fmi2DoStep (t + h) - t.  It drops every String parameter
  value of an SSD (OMSimulator 2940ef11: ``ComponentFMUCS::setResourcesHelper1`` sets Boolean, Integer and Real
  start values only; the Python layer calls ``oms_setString`` before instantiation and the library never passes
  it to the FMU), so in the B scenarios its strategies fly A: the run equals cosim-master's run of the same SSP
  with ``strategy=A`` to rounding, and with the String values set through its API after instantiation it equals
  cosim-master's run of the SSP as it is, to rounding.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest
from peer_runs import SSP_DIR, Job, absent

import master
from uavstudy.build import PARAMETER_SET

SSPS = sorted(p.stem for p in SSP_DIR.glob("paper_*.ssp"))
STOP, STEP = 20.0, 0.1
N = int(round(STOP / STEP))
ATOL = 1e-9
PER_UAV = [("dyn", "x", "Real"), ("dyn", "y", "Real"), ("dyn", "z", "Real"), ("bat", "soc", "Real"),
           ("dyn", "phase", "Integer"), ("strat", "cmd", "Integer"), ("strat", "mission_state", "Integer"),
           ("strat", "current_target", "Integer"), ("strat", "photo_count", "Integer")]


def _uavs(name):
    return 4 if "4uav" in name else 1


def _variables(name):
    return [[f"uav{k}_{c}", v, t] for k in range(1, _uavs(name) + 1) for c, v, t in PER_UAV]


def _strategy_b(name):
    return name.endswith("_B")


def _ours(name, **params):
    """Our run, up to the row of the first collision: from there the UAV monitor removes the UAVs involved
    (strategy A's four UAVs collide from t = 18.47 s, the paper's finding), which the peers, running no monitor,
    do not. Run once per scenario and parameters, whichever peer it is compared with (runs are deterministic)."""
    return _our_run(name, tuple(sorted(params.items())))


@functools.lru_cache(maxsize=None)
def _our_run(name, params):
    result = master.run(SSP_DIR / f"{name}.ssp", output=None, algorithm="jacobi", step=STEP, stop_time=STOP,
                        record_interval=STEP, record=[f"{c}.{v}" for c, v, _ in _variables(name)],
                        params=dict(params) or None)
    frame = result.frame
    hits = [e["time"] for e in result.events if e.get("event") == "collision"]
    return frame[frame["time"] < min(hits) + STEP] if hits else frame


def uav_peer_jobs(peer, tmp_path_factory) -> dict:
    """This module's jobs for ``peer`` ({(scenario, strings set): Job}), run in the session's child of that peer
    with the other modules' (conftest.py)."""
    jobs = {(n, False): Job(str(SSP_DIR / f"{n}.ssp"), STEP, N, _variables(n),
                            options={"parameter_set": PARAMETER_SET}) for n in SSPS}
    if peer == "omsimulator":        # the B scenarios once more, with the String values it drops set by hand
        jobs.update({(n, True): Job(str(SSP_DIR / f"{n}.ssp"), STEP, N, _variables(n), set_strings=True)
                     for n in SSPS if _strategy_b(n)})
    return jobs


@pytest.fixture(scope="module", params=["omsimulator", "ecos", "libcosim"])
def peer_runs(request, uav_peer_runs):
    peer = request.param
    why = absent(peer)
    if why:
        pytest.skip(why)
    return peer, uav_peer_runs(peer, request.module)


def _compare(ours, theirs, name) -> float:
    """Integers equal, reals within ATOL at every row of ours (``_ours``); the largest real difference."""
    assert len(theirs) == N + 1 and 170 < len(ours) <= N + 1       # past the takeoff (16 s)
    theirs = theirs.iloc[:len(ours)]
    np.testing.assert_allclose(theirs["time"], ours["time"], rtol=0, atol=1e-9)
    worst = 0.0
    for c, v, t in _variables(name):
        key = f"{c}.{v}"
        a, b = ours[key].to_numpy(), theirs[key].to_numpy()
        if t == "Integer":
            assert np.array_equal(a.astype(int), b.astype(int)), key
        else:
            np.testing.assert_allclose(b, a, rtol=0, atol=ATOL, err_msg=key)
            worst = max(worst, float(np.max(np.abs(a - b))))
    return worst


@pytest.mark.parametrize("name", SSPS)
def test_uav_ssp_in_peer(peer_runs, name, record_property):
    peer, runs = peer_runs
    theirs = runs[(name, False)]
    ours = _ours(name)
    # the window saw every UAV take off and head for a target
    assert all(theirs[f"uav{k}_dyn.z"].max() > 19.0 for k in range(1, _uavs(name) + 1))
    assert all((theirs[f"uav{k}_strat.current_target"] >= 0).any() for k in range(1, _uavs(name) + 1))
    if peer == "omsimulator" and _strategy_b(name):
        # the named difference: its strategies fly A (the String 'B' dropped) ...
        as_a = _ours(name, **{f"uav{k}_strat.strategy": "A" for k in range(1, _uavs(name) + 1)})
        worst = _compare(as_a, theirs, name)
        first = [f"uav{k}_strat.current_target" for k in range(1, _uavs(name) + 1)]
        assert not all(np.array_equal(ours[k], theirs[k].iloc[:len(ours)]) for k in first)   # ... which is not B
        # ... and with the String values set after instantiation it flies the SSP's mission
        worst = max(worst, _compare(ours, runs[(name, True)], name))
    else:
        worst = _compare(ours, theirs, name)
        if peer == "ecos":
            # our last step ends exactly at the stop time (stop - t, FMI 2.0 fmi2SetupExperiment: no step past
            # it), where Ecos steps h from its summed clock: that last row agrees to rounding, every other bit for bit
            before_stop = ours[ours["time"] < STOP - STEP / 2]
            assert _compare(before_stop, theirs, name) == 0.0, "not bit-identical before the last step"
    record_property("max_abs_diff", worst)
