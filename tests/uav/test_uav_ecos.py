"""The shipped mission ssp/paper_free_1uav_B.ssp runs in Ecos (ecospy) as in cosim-master (Jacobi).

The SSP is given to Ecos unchanged; Ecos applies its parameters when ``init`` names the parameter set that
every component's binding carries (``uavstudy.build.PARAMETER_SET``, see tests/peers/ecos_runner.py).
Before that (one set name per component) Ecos applied no parameter at all: the UAV had no targets, took off
and landed at once.  Both masters step all components from the previous step's outputs (Jacobi), at the
SSP's 0.1 s step, until cosim-master's run ends (the fleet has landed).

Bit-identical, measured (2026-11-23, ecospy 0.7.2: max difference 0 in x, y, z and soc over all 8251
communication points), although Ecos's clock is a sum (t_{n+1} = t_n + h: t_61 = 6.099999999999994 where we
compute n * h = 6.1): Ecos passes fmi2DoStep exactly h, the models advance on h (the dynamics' preflight
check counts elapsed step sizes, with a 1e-9 s tolerance) and the scenario has no wind (the only model whose
output depends on t itself).  Only the photo *times* carry t, so they differ by the clock's rounding (not
compared).  Integers (photo count, photographed targets in order, mission state) are compared exactly.
"""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import master
from uavstudy.build import PARAMETER_SET

TESTS = Path(__file__).resolve().parents[1]
SSP = TESTS.parent / "ssp" / "paper_free_1uav_B.ssp"
STEP = 0.1
VARIABLES = [("uav1_dyn", "x", "Real"), ("uav1_dyn", "y", "Real"), ("uav1_dyn", "z", "Real"),
             ("uav1_bat", "soc", "Real"), ("uav1_strat", "photo_count", "Integer"),
             ("uav1_strat", "last_photo_target", "Integer"), ("uav1_strat", "mission_state", "Integer")]
REALS = ["uav1_dyn.x", "uav1_dyn.y", "uav1_dyn.z", "uav1_bat.soc"]
INTEGERS = ["uav1_strat.photo_count", "uav1_strat.last_photo_target", "uav1_strat.mission_state"]

pytestmark = [
    pytest.mark.skipif(importlib.util.find_spec("ecospy") is None, reason="ecospy not installed"),
    pytest.mark.skipif(not SSP.is_file(), reason=f"{SSP.name} not built (python ssp/build_all.py)"),
]

_ECOS_SCRIPT = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
from peers.ecos_runner import run_ecos
ssp, step, n, out, variables, pset = sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), sys.argv[5], sys.argv[6], sys.argv[7]
run_ecos(ssp, step, n, [tuple(v) for v in json.loads(variables)], pset).to_parquet(out)
"""


def _run_ecos_child(n_steps: int, out: Path) -> pd.DataFrame:
    """Ecos in a child process: it runs the pythonfmu binaries, which re-enter the interpreter, and a failure
    there must not take the test session with it."""
    proc = subprocess.run([sys.executable, "-c", _ECOS_SCRIPT, str(TESTS), str(SSP), repr(STEP), str(n_steps),
                           str(out), json.dumps(VARIABLES), PARAMETER_SET],
                          capture_output=True, text=True, timeout=600)
    if proc.returncode != 0 and "libtbb" in proc.stderr:
        pytest.skip("ecospy cannot load libtbb.so.12 (pip install tbb)")
    assert proc.returncode == 0, f"Ecos run failed ({proc.returncode}):\n{proc.stderr[-3000:]}"
    return pd.read_parquet(out)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    ours = master.run(SSP, output=None, algorithm="jacobi", step=STEP, record_interval=STEP,
                      record=[f"{c}.{v}" for c, v, _ in VARIABLES]).frame
    theirs = _run_ecos_child(len(ours) - 1, tmp_path_factory.mktemp("ecos") / "ecos.parquet")
    return ours, theirs


def _photo_order(frame: pd.DataFrame) -> list[int]:
    """Global target indices in the order they were photographed."""
    got = frame["uav1_strat.last_photo_target"].to_numpy()
    return [int(k) for k in got[np.flatnonzero(np.diff(got, prepend=-1))] if k >= 0]


def test_paper_free_1uav_B_same_mission_in_ecos(runs, record_property):
    ours, theirs = runs
    assert len(theirs) == len(ours)
    np.testing.assert_allclose(theirs["time"], ours["time"], rtol=0, atol=1e-9)     # Ecos's summed clock
    diff = {k: float(np.max(np.abs(ours[k].to_numpy() - theirs[k].to_numpy()))) for k in REALS}
    record_property("max_abs_diff", json.dumps(diff))
    last = theirs.iloc[-1]
    # the mission really flew in Ecos: all 24 targets photographed, landed on the base
    assert last["uav1_strat.photo_count"] == 24 and last["uav1_strat.mission_state"] == 7
    assert sorted(_photo_order(theirs)) == list(range(24))
    for k in INTEGERS:
        assert np.array_equal(ours[k].to_numpy(), theirs[k].to_numpy()), k
    assert diff == dict.fromkeys(REALS, 0.0), f"not bit-identical: {diff}"
