"""The SITL vehicle FMU (fmus/UavSitl.fmu) in UAV scenarios run by cosim-master.

Without the binary: the faults a user meets first (no binary, a crashing one, one that never answers) end the run
with a one-line error naming the UAV's component; the scenario's ``sitl.frame_rate`` and ``sitl.gcs_port`` reach
the firmware's command line (a stand-in records it) and round-trip through YAML.  With the real ArduCopter SITL ($ARDUPILOT_SITL, else
../shared/sitl/arducopter; skipped with the reason when absent): a short mission flown in lock-step and paced,
two lock-step runs bit-identical, four SITL UAVs in one process on distinct instances, a killed SITL reported
cleanly; after every run no SITL process is left.  The expected flights follow from the scenario (target
position, takeoff altitude, home pad) and the firmware's documented behaviour (GUIDED takeoff climbs to the
requested altitude, LAND ends disarmed on the ground).
"""
from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from pathlib import Path

import pytest
from sitlveh_helpers import lean_sitl, real_binary

import master
from master.observers import Observer
from sitlsim.vehicle import SitlConfig, SitlFault, SitlVehicle
from uavsim.geodesy import EnuFrame
from uavstudy.build import build_ssp
from uavstudy.scenario import SitlOptions, UavScenario

BASE = (-7.275, -35.965, 540.0)
BINARY, WHY = real_binary()
needs_sitl = pytest.mark.skipif(BINARY is None, reason=f"{WHY}: the real-SITL tests are skipped")
# the firmware's fastest landing (2 m/s; default 0.5 m/s): the short mission still ends landed and disarmed,
# a few seconds of flight sooner
QUICK_LANDING = {"LAND_SPEED": 200.0}


def scenario(tmp_path, *, n_uavs=1, targets=((30.0, 20.0),), coupling="lockstep", stop=120.0, name="s",
             takeoff=5.0, vehicle="sitl", lean=True) -> Path:
    """The short mission; ``lean``: at the test rates, headless (sitlveh_helpers.lean_sitl: no assertion of these
    tests depends on the firmware's frame or loop rate), else the shipped FMU's defaults."""
    fr = EnuFrame(*BASE)
    latlon = [fr.to_geodetic(x, y, 0.0)[:2] for x, y in targets]
    sitl = (SitlOptions(coupling=coupling, speedup=80.0, **lean_sitl(**QUICK_LANDING)) if lean else
            SitlOptions(coupling=coupling, speedup=80.0, params=QUICK_LANDING))
    scn = UavScenario(name=name, base=BASE, n_uavs=n_uavs, strategy="B", targets=latlon,
                      takeoff_altitude=takeoff, stop_time=stop, seed=3, vehicle=vehicle, sitl=sitl)
    return build_ssp(scn, tmp_path / f"{name}.ssp")


def sitl_pids(under: Path) -> list[int]:
    """arducopter-like processes whose working folder lies under ``under``."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if os.readlink(d / "cwd").startswith(str(under)) and int(d.name) != os.getpid():
                    out.append(int(d.name))
            except OSError:
                pass
    return out


def run(ssp, out, **kw):
    return master.run(ssp, output=out, raise_on_error=False, write_csv=False, **kw)


def error_of(result) -> str:
    return result.metadata.get("error") or ""


# ------------------------------------------------------------------------------------------ without the binary
@pytest.fixture
def fake_binaries(tmp_path):
    crash = tmp_path / "crash_sitl"
    crash.write_text("#!/bin/sh\necho 'fake SITL: cannot open eeprom' >&2\nexit 3\n")
    silent = tmp_path / "silent_sitl"
    silent.write_text(f"#!{sys.executable}\nimport signal, time\nsignal.signal(signal.SIGTERM, signal.SIG_IGN)\n"
                      "time.sleep(600)\n")
    for f in (crash, silent):
        f.chmod(0o755)
    return {"crash": str(crash), "silent": str(silent)}


@pytest.mark.parametrize("case, expected", [
    ("missing", "SITL binary not found: .*nope"),
    ("crash", "exited with code 3"),
    ("silent", "does not listen on 127.0.0.1:.* after 1.5 s of wall clock"),
])
def test_faults_end_the_run_with_one_line_naming_the_uav(tmp_path, fake_binaries, case, expected):
    ssp = scenario(tmp_path)
    binary = str(tmp_path / "nope") if case == "missing" else fake_binaries[case]
    res = run(ssp, tmp_path / "out", params={"uav1_dyn.sitl_binary": binary, "uav1_dyn.wall_timeout": 1.5})
    msg = error_of(res)
    assert res.metadata["outcome"] == "error"
    assert "\n" not in msg and "uav1_dyn" in msg and "t=0" in msg
    import re
    assert re.search(expected, msg), msg
    assert json.loads((tmp_path / "out" / "run.json").read_text())["outcome"] == "error"
    assert sitl_pids(tmp_path) == []


@pytest.mark.parametrize("lean", [False, True])
def test_the_scenarios_rates_and_ports_reach_the_firmwares_command_line(tmp_path, lean):
    """scenario -> SSP -> UavSitl -> the firmware's command line and cosim.parm, read by a stand-in firmware
    that records them: the shipped default asks for no rate and keeps SITL's ground-station ports; the lean test
    scenario asks for 400 frames a second, SERIAL1 and SERIAL2 off, and its loop rate in the parameter file."""
    fake = tmp_path / "record_sitl"
    fake.write_text(f"#!{sys.executable}\nimport json, pathlib, sys\n"
                    "parm = sys.argv[sys.argv.index('--defaults') + 1].split(',')[-1]\n"
                    "pathlib.Path('argv.json').write_text(json.dumps([sys.argv[1:], pathlib.Path(parm).read_text()]))\n"
                    "sys.exit(3)\n")
    fake.chmod(0o755)
    res = run(scenario(tmp_path, lean=lean), tmp_path / "out", params={"uav1_dyn.sitl_binary": str(fake)})
    assert "exited with code 3" in error_of(res)
    argv, parm = json.loads((tmp_path / "out" / "sitl" / "uav1_dyn" / "argv.json").read_text())
    pairs = {a: b for a, b in zip(argv, argv[1:]) if a.startswith("--")}
    if lean:
        assert (pairs["--rate"], pairs["--serial1"], pairs["--serial2"]) == ("400", "none", "none")
        assert "SCHED_LOOP_RATE 200" in parm.splitlines()
    else:
        assert not {"--rate", "--serial1", "--serial2"} & set(argv)
        assert "SCHED_LOOP_RATE" not in parm
    assert "LAND_SPEED 200" in parm.splitlines()


def test_the_sitl_rates_and_ports_round_trip_through_yaml_and_bad_values_are_named(tmp_path):
    from master.errors import ScenarioError
    from uavstudy.scenario import dump_scenario_yaml, load_scenario_yaml, scenario_to_dict
    fr = EnuFrame(*BASE)
    target = [fr.to_geodetic(30.0, 20.0, 0.0)[:2]]
    lean = UavScenario(name="lean", base=BASE, n_uavs=1, strategy="B", targets=target, vehicle="sitl",
                       sitl=SitlOptions(**lean_sitl()))
    shipped = UavScenario(name="shipped", base=BASE, n_uavs=1, strategy="B", targets=target, vehicle="sitl")
    for scn in (lean, shipped):
        dump_scenario_yaml(scn, tmp_path / f"{scn.name}.yaml")
        assert load_scenario_yaml(tmp_path / f"{scn.name}.yaml").sitl == scn.sitl
    assert [(d["frame_rate"], d["gcs_port"]) for d in (scenario_to_dict(x)["sitl"] for x in (lean, shipped))] == \
        [(400, False), (0, True)]
    # ordinary scenario fields: a campaign may sweep them
    from uavstudy.campaign_kind import _field_paths
    assert {"sitl.frame_rate", "sitl.gcs_port"} <= set(_field_paths())
    text = (tmp_path / "lean.yaml").read_text()
    for bad, msg in [("frame_rate: 400", "frame_rate: -5"), ("gcs_port: false", "gcs_port: 0")]:
        (tmp_path / "bad.yaml").write_text(text.replace(bad, msg))
        with pytest.raises(ScenarioError) as err:
            load_scenario_yaml(tmp_path / "bad.yaml")
        name = msg.split(":")[0]
        want = "must be >= 0, got -5" if name == "frame_rate" else "expected true or false, got 0"
        assert str(err.value) == f"{tmp_path / 'bad.yaml'}: sitl.{name}: {want}"


def test_a_negative_frame_rate_is_refused_before_anything_starts():
    with pytest.raises(SitlFault, match=r"frame_rate must be 0 \(the firmware's own\) or positive, not -400"):
        SitlVehicle(SitlConfig(frame_rate=-400))


def test_no_binary_at_all_says_how_to_provide_one(tmp_path, monkeypatch):
    monkeypatch.delenv("ARDUPILOT_SITL", raising=False)
    res = run(scenario(tmp_path), tmp_path / "out")
    assert "set the parameter 'sitl_binary' or the environment variable ARDUPILOT_SITL" in error_of(res)


# ------------------------------------------------------------------------------------------ with the real binary
@pytest.fixture
def sitl_env(monkeypatch):
    monkeypatch.setenv("ARDUPILOT_SITL", BINARY or "")


def _summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def _uav(summary: dict, name="uav1") -> dict:
    return next(u for u in summary["uavs"] if u["uav"] == name)


def _check_short_mission(out: Path, frame, takeoff=5.0, target=(30.0, 20.0)):
    s = _uav(_summary(out))
    assert s["outcome"] == "success" and s["targets_visited"] == 1
    z = frame["uav1_dyn.z"]
    assert takeoff - 1.0 < z.max() < takeoff + 1.5          # GUIDED takeoff to the requested altitude
    d = ((frame["uav1_dyn.x"] - target[0]) ** 2 + (frame["uav1_dyn.y"] - target[1]) ** 2) ** 0.5
    assert d.min() < 3.0                                      # it went to the target
    assert abs(frame["uav1_dyn.x"].iloc[-1]) < 2.0 and abs(frame["uav1_dyn.y"].iloc[-1]) < 2.0   # back home
    assert z.iloc[-1] < 0.2 and frame["uav1_dyn.armed"].iloc[-1] == 0                          # landed, disarmed
    assert (out / "sitl" / "uav1_dyn" / "eeprom.bin").is_file()
    assert sitl_pids(out) == []


class StallAfterSteps(Observer):
    """After the given steps, holds the master for ``pause`` s of wall clock (SITL, waiting for its answer,
    re-sends its servo frame after ~1 s) and then stops the SITL process for ``hold`` s, so that the next
    doStep answers the frame while SITL is frozen and meets the re-sent copy with no newer frame behind it:
    the two wall-clock accidents a loaded machine produces, made certain (docs/sitl_physics.md,
    "Re-sent frames")."""

    def __init__(self, under: Path, steps, pause=1.5, hold=0.6):
        """steps: step numbers, or {step: (pause, hold)} for a pause and hold of its own at each."""
        self.under = under
        self.steps = dict(steps) if isinstance(steps, dict) else {n: (pause, hold) for n in steps}
        self.stalled: list[int] = []
        self.timers = []

    def after_step(self, n, t0, t1):
        if n not in self.steps:
            return
        pause, hold = self.steps[n]
        time.sleep(pause)
        pids = sitl_pids(self.under)
        for pid in pids:
            os.kill(pid, signal.SIGSTOP)
        timer = threading.Timer(hold, self._resume, (pids,))
        timer.start()
        self.timers.append(timer)
        self.stalled.append(n)

    @staticmethod
    def _resume(pids):
        for pid in pids:
            try:
                os.kill(pid, signal.SIGCONT)
            except ProcessLookupError:
                pass


@needs_sitl
def test_lockstep_mission_is_flown_and_bit_identical_when_repeated(tmp_path, sitl_env):
    ssp = scenario(tmp_path)
    a = run(ssp, tmp_path / "a")
    assert a.metadata["outcome"] == "completed", error_of(a)
    fa = a.frame
    _check_short_mission(tmp_path / "a", fa)
    assert (fa["uav1_dyn.flight_mode"] == 4).any() and (fa["uav1_dyn.flight_mode"] == 9).any()  # GUIDED, LAND
    assert (fa["uav1_dyn.slip"] == 0.0).all()
    # the second run is stalled where the first was not: lock-step must not see the wall clock
    stall = StallAfterSteps(tmp_path / "b", steps=(15, 120))     # during the takeoff and on the way out
    try:
        b = run(ssp, tmp_path / "b", observers=[stall])
    finally:
        for timer in stall.timers:
            timer.join()
    assert b.metadata["outcome"] == "completed", error_of(b)
    assert stall.stalled == [15, 120]
    assert "resending servos" in (tmp_path / "b" / "sitl" / "uav1_dyn" / "sitl.log").read_text()
    fb = b.frame
    assert list(fa.columns) == list(fb.columns) and len(fa) == len(fb)
    # the whole recorded table: which SITL instance was free (bookkeeping) is in run.json, not in the results
    assert not any(c.endswith("sitl_instance") for c in fa.columns)
    diff = [col for col in fa.columns if not fa[col].equals(fb[col])]
    assert not diff, f"{', '.join(diff)} differ between lock-step runs"
    assert (tmp_path / "a" / "results.parquet").read_bytes() == (tmp_path / "b" / "results.parquet").read_bytes()


@needs_sitl
def test_paced_mission_is_flown_and_reports_its_slip(paced_mission):
    res = paced_mission.result          # shared with test_sitl_mission.py (conftest.py)
    assert res.metadata["outcome"] == "completed", error_of(res)
    f = res.frame
    _check_short_mission(paced_mission.out, f)
    slip = f["uav1_dyn.slip"]
    # the vehicle clock is at or past each communication point; by how much depends on the machine's load
    assert (slip >= 0.0).all() and slip.median() < 0.5


@needs_sitl
def test_four_sitl_uavs_in_one_process_on_distinct_instances(sitl_fleet):
    """Four SITL UAVs (and a point-mass one) in one run: the run shared with test_sitl_parallel.py and
    test_sitl_mission.py (conftest.py, ``sitl_fleet``)."""
    res = sitl_fleet.result
    assert res.metadata["outcome"] == "completed", error_of(res)
    f = res.frame
    vehicles = res.metadata["monitors"]["org.cosim-master.sitl-clock"]["vehicles"]
    instances = {vehicles[f"uav{k}_dyn"]["sitl_instance"] for k in range(1, 5)}
    assert len(instances) == 4 and min(instances) >= 0      # four SITLs, four port sets
    for k in range(1, 5):
        assert f[f"uav{k}_dyn.z"].max() > 2.0, f"uav{k} did not take off"
        assert (sitl_fleet.out / "sitl" / f"uav{k}_dyn" / "eeprom.bin").is_file()
    assert sitl_pids(sitl_fleet.under) == []


class KillSitlAt(Observer):
    """Kills the SITL process of the run with SIGKILL once the mission clock passes ``at``."""

    def __init__(self, under: Path, at: float):
        self.under, self.at, self.killed = under, at, []

    def after_step(self, n, t0, t1):
        if t1 >= self.at and not self.killed:
            self.killed = sitl_pids(self.under)
            for pid in self.killed:
                os.kill(pid, signal.SIGKILL)


#: the vehicle's wall_timeout in the killed-SITL test: far longer than the whole run takes (get-ready and 3 s of
#: mission, seconds of wall clock even on a loaded machine), so an error before it comes from the firmware's exit
KILLED_WALL_TIMEOUT = 90.0


@needs_sitl
def test_a_killed_sitl_is_reported_cleanly_and_the_results_are_kept(tmp_path, sitl_env):
    out = tmp_path / "k"
    killer = KillSitlAt(out, 3.0)
    t0 = time.monotonic()
    res = run(scenario(tmp_path), out, observers=[killer], params={"uav1_dyn.wall_timeout": KILLED_WALL_TIMEOUT})
    # the lock-step wait noticed the firmware's death (it asks every 0.5 s) instead of waiting for its frames
    # until wall_timeout (it did, 30 s of idle wall clock per killed SITL, before)
    assert time.monotonic() - t0 < KILLED_WALL_TIMEOUT
    assert killer.killed
    msg = error_of(res)
    assert res.metadata["outcome"] == "error"
    assert "\n" not in msg and "uav1_dyn" in msg and "killed by signal 9" in msg, msg
    assert "t=3" in msg
    from master.results import read_results
    f = read_results(out)
    assert f["time"].max() >= 2.0                            # what was recorded before stays
    assert sitl_pids(tmp_path) == []


def _dataflash_bytes(out: Path) -> int:
    return sum(f.stat().st_size for f in (out / "sitl").glob("*/logs/*.BIN"))


@needs_sitl
def test_ctrl_c_on_the_cli_leaves_no_sitl_and_keeps_the_results(tmp_path, sitl_env):
    import subprocess

    import program_server           # the Ctrl-C comes in the firmware's get-ready, long after the CLI's imports
    out = tmp_path / "cc"
    ssp = scenario(tmp_path, stop=300.0)
    cli = program_server.Popen([sys.executable, "-m", "master.cli", "run", str(ssp), "-o", str(out)],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        end = time.monotonic() + 120
        while not sitl_pids(out) and time.monotonic() < end and cli.poll() is None:
            time.sleep(0.1)
        assert sitl_pids(out), "SITL did not start"
        # into the get-ready: the firmware's DataFlash log (open from boot, LOG_DISARMED 1) grows only while
        # lock-step frames are answered, so its size shows the exchange under way whatever the machine's load
        while _dataflash_bytes(out) < 64 * 1024 and time.monotonic() < end and cli.poll() is None:
            time.sleep(0.05)
        assert _dataflash_bytes(out) >= 64 * 1024, "no lock-step frames answered"
        cli.send_signal(signal.SIGINT)
        err = cli.communicate(timeout=60)[1]
    finally:
        if cli.poll() is None:
            cli.kill()
    assert cli.returncode != 0
    assert "interrupted" in err
    assert json.loads((out / "run.json").read_text())["outcome"] == "interrupted"
    assert sitl_pids(tmp_path) == []
