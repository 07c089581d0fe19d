"""The four UAV FMU shells: build (into tmp_path), validate, simulate briefly with FMPy; and the
shipped fmus/ must be fresh (built from the current fmu_sources/)."""
import contextlib
import re
import shutil
import sys
import textwrap
import zipfile
from pathlib import Path

import pytest
# A pythonfmu FMU run in this process puts its resources (with a binary-less copy of pythonfmu) first on
# sys.path; importing the installed pythonfmu now keeps the builder below from picking up that copy.
import pythonfmu.builder  # noqa: F401
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

import program_server
from build_script import build_fmus_module, load_shell

REPO = Path(__file__).resolve().parents[3]
SRC = REPO / "fmu_sources"


bf = build_fmus_module()

# connector contract (docs/uav_connectors.md): name -> (causality, type)
CONTRACT = {
    "UavDynamics": {
        "cmd": ("input", "Integer"), "sp_x": ("input", "Real"), "sp_y": ("input", "Real"),
        "sp_z": ("input", "Real"), "wind_x": ("input", "Real"), "wind_y": ("input", "Real"),
        "wind_z": ("input", "Real"), "x": ("output", "Real"), "y": ("output", "Real"),
        "z": ("output", "Real"), "vx": ("output", "Real"), "vy": ("output", "Real"),
        "vz": ("output", "Real"), "lat": ("output", "Real"), "lon": ("output", "Real"),
        "alt": ("output", "Real"), "airspeed": ("output", "Real"), "groundspeed": ("output", "Real"),
        "phase": ("output", "Integer"), "origin_lat": ("parameter", "Real"),
        "origin_lon": ("parameter", "Real"), "origin_alt": ("parameter", "Real"),
        "home_x": ("parameter", "Real"), "home_y": ("parameter", "Real"),
        "takeoff_altitude": ("parameter", "Real")},
    "UavBattery": {
        "airspeed": ("input", "Real"), "vz": ("input", "Real"), "phase": ("input", "Integer"),
        "soc": ("output", "Real"), "consumed": ("output", "Real"), "voltage": ("output", "Real"),
        "current": ("output", "Real"), "power": ("output", "Real"), "energy_used": ("output", "Real")},
    "UavWind": {
        "wind_x": ("output", "Real"), "wind_y": ("output", "Real"), "wind_z": ("output", "Real"),
        "wind_speed": ("output", "Real"), "wind_level": ("output", "Integer"),
        "probability": ("parameter", "Real"), "seed": ("parameter", "Integer"),
        "direction_deg": ("parameter", "Real")},
    "UavStrategy": {
        "x": ("input", "Real"), "y": ("input", "Real"), "z": ("input", "Real"),
        "vx": ("input", "Real"), "vy": ("input", "Real"), "phase": ("input", "Integer"),
        "consumed": ("input", "Real"), "cmd": ("output", "Integer"), "sp_x": ("output", "Real"),
        "sp_y": ("output", "Real"), "sp_z": ("output", "Real"),
        "mission_state": ("output", "Integer"), "targets_assigned": ("output", "Integer"),
        "targets_visited": ("output", "Integer"), "photo_count": ("output", "Integer"),
        "last_photo_target": ("output", "Integer"), "last_photo_time": ("output", "Real"),
        "last_photo_x": ("output", "Real"), "last_photo_y": ("output", "Real"),
        "strategy": ("parameter", "String"), "uav_index": ("parameter", "Integer"),
        "uav_count": ("parameter", "Integer"), "assignment": ("parameter", "String"),
        "targets": ("parameter", "String"), "zones": ("parameter", "String"),
        "lookahead": ("parameter", "Real"), "home_x": ("parameter", "Real"),
        "home_y": ("parameter", "Real"), "cruise_altitude": ("parameter", "Real"),
        "return_threshold": ("parameter", "Real"), "land_threshold": ("parameter", "Real")},
}

# strategy C's channel (docs/cooperative.md): one broadcast in and k message slots out per UAV, the counters
CONTRACT["UavChannel"] = {
    "uav1_x": ("input", "Real"), "uav64_clock": ("input", "Real"), "uav1_claims0": ("input", "Integer"),
    "uav1_m1_x": ("output", "Real"), "uav64_m4_sender": ("output", "Integer"), "uav1_m1_visited1": ("output", "Integer"),
    "messages_sent": ("output", "Integer"), "messages_lost": ("output", "Integer"), "near_misses": ("output", "Integer"),
    "range": ("parameter", "Real"), "loss": ("parameter", "Real"), "latency": ("parameter", "Real"),
    "period": ("parameter", "Real"), "k": ("parameter", "Integer"), "mode": ("parameter", "String")}

# the SITL vehicle (docs/sitl.md): UavDynamics' connectors plus what SITL adds
CONTRACT["UavSitl"] = {**CONTRACT["UavDynamics"], "flight_mode": ("output", "Integer"),
                       "armed": ("output", "Integer"), "ekf_ok": ("output", "Integer"), "slip": ("output", "Real"),
                       "sitl_binary": ("parameter", "String"), "coupling": ("parameter", "String"),
                       "speedup": ("parameter", "Real"), "instance": ("parameter", "Integer")}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("fmus")
    return {n: bf.build_fmu(n, out) for n in bf.FMU_NAMES}


@contextlib.contextmanager
def _names_parsed_once_per_shape():
    """fmpy's validate_fmu parses every variable name with an Earley parser (lark) for the structured naming
    convention: ~2 ms a name, 11 s of CPU for UavChannel's 4946 names, nearly all of them one of a few dozen shapes
    (uav1_m1_x ... uav64_m4_x). In that grammar a digit is only ever one of ``digit*``/``digit+``/``qchar*`` (in a
    name after its first character, in an array index, in a quoted name), so a name is legal exactly when it is
    with each run of digits written as one digit: one parse per shape gives every name's verdict."""
    import lark

    parse, seen = lark.Lark.parse, {}

    def once_per_shape(self, text, *args, **kwargs):
        shape = re.sub(r"[0-9]+", "0", text)
        if shape not in seen:
            try:
                parse(self, shape, *args, **kwargs)
                seen[shape] = None
            except Exception as exc:        # noqa: BLE001 - kept, and raised for every name of that shape
                seen[shape] = exc
        if seen[shape] is not None:
            raise seen[shape]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(lark.Lark, "parse", once_per_shape)
        yield


def test_names_parsed_once_per_shape_keep_fmpys_verdicts():
    """The shortcut above gives fmpy's own verdicts: legal names pass, and each illegal one is still named."""
    from types import SimpleNamespace

    from fmpy.validation import _validate_variable_names
    legal = ["x", "uav12_m3_x", "uav1_m3_x", "a.b[12,3]", "der(uav7_x,2)", "'q 1'", "_9"]
    illegal = ["1x", "12x", "uav1..x", "a[]", "x[1.5]", "7", "x[01,]"]
    md = SimpleNamespace(variableNamingConvention="structured",
                         modelVariables=[SimpleNamespace(name=n, sourceline=i) for i, n in enumerate(legal + illegal)])
    plain = _validate_variable_names(md)
    with _names_parsed_once_per_shape():
        shortcut = _validate_variable_names(md)
    named = [[n for n in legal + illegal if f'"{n}" (line' in problem] for problem in plain]
    assert named == [[n] for n in illegal]
    assert [p.split(". ")[0] for p in shortcut] == [p.split(". ")[0] for p in plain]


@pytest.mark.parametrize("name", bf.FMU_NAMES)
def test_fmu_valid_and_contract(built, name):
    fmu = built[name]
    with _names_parsed_once_per_shape():
        assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    vars_ = {v.name: v for v in md.modelVariables}
    for vname, (caus, typ) in CONTRACT[name].items():
        assert vname in vars_, vname
        assert vars_[vname].causality == caus and vars_[vname].type == typ, vname
        if typ == "Real" and caus == "parameter":
            assert vars_[vname].unit, f"{vname} has no unit"
    with zipfile.ZipFile(fmu) as z:
        names = z.namelist()
    assert "resources/uavsim/dynamics.py" in names and "resources/sources.sha256" in names


def test_dynamics_fmu_takeoff(built):
    # preflight 5 s + climb to 10 m (~11 s total with the 2.5 m/s climb and braking)
    r = simulate_fmu(str(built["UavDynamics"]), stop_time=20.0, step_size=0.5, output_interval=0.5,
                     start_values={"cmd": 1, "takeoff_altitude": 10.0, "origin_alt": 100.0})
    assert r["phase"][0] == 0 and r["phase"][-1] == 2
    assert r["z"][-1] == pytest.approx(10.0, abs=0.05)
    assert r["alt"][-1] == pytest.approx(110.0, abs=0.05)
    assert r["lat"][-1] == pytest.approx(-7.2153, abs=1e-7)


def test_battery_fmu_hover(built):
    # 60 s hover: 191.9 W; current ~16 A; consumed ~ 16 A * 60 s / 18360 C = 0.052
    r = simulate_fmu(str(built["UavBattery"]), stop_time=60.0, step_size=1.0, output_interval=1.0,
                     start_values={"phase": 2})
    assert r["power"][-1] == pytest.approx(191.92, abs=0.05)
    assert r["consumed"][-1] == pytest.approx(0.052, abs=0.002)
    assert r["soc"][-1] == pytest.approx(1 - r["consumed"][-1])


def test_wind_fmu_matches_python_model(built):
    from uavsim.wind import Wind, WindParams
    r = simulate_fmu(str(built["UavWind"]), stop_time=100.0, step_size=0.5, output_interval=0.5,
                     start_values={"probability": 0.5, "seed": 3, "turbulence": True, "step_mean": False})
    w = Wind(WindParams(probability=0.5, seed=3, turbulence=True))
    for t, wx, lvl in zip(r["time"], r["wind_x"], r["wind_level"]):
        ex, _, _, el = w.at(float(t))
        assert wx == ex and lvl == el


def test_wind_fmu_step_mean_gives_the_same_impulse_for_any_step(built):
    # episodes of 1 s with 0.25 s ramps: sampled at whole seconds the wind would always be 0
    sv = {"probability": 0.6, "seed": 5, "decision_interval": 1.0, "duration": 1.0, "ramp": 0.25}
    from uavsim.wind import Wind, WindParams
    w = Wind(WindParams(probability=0.6, seed=5, decision_interval=1.0, duration=1.0, ramp=0.25))
    for h in (0.1, 0.5, 1.0):
        # integral of wind_x over [h, 60] (the first step holds the value at t = 0: the step is not yet known)
        n = int(round((60.0 - h) / 0.001))
        exact = sum(w.at(h + (j + 0.5) * 0.001)[0] for j in range(n)) * 0.001
        r = simulate_fmu(str(built["UavWind"]), stop_time=60.0, step_size=h, output_interval=h, start_values=sv)
        held = float(sum(r["wind_x"][1:-1])) * h        # what a zero-order hold delivers over [h, 60]
        assert exact < -10.0                            # the wind really blew
        assert held == pytest.approx(exact, rel=2e-3), h


def test_strategy_fmu_assignment_and_command(built):
    r = simulate_fmu(str(built["UavStrategy"]), stop_time=2.0, step_size=1.0, output_interval=1.0,
                     start_values={"strategy": "B", "targets": "1,2;3,4;5,6;7,8", "uav_count": 2,
                                   "uav_index": 1, "phase": 2})
    # equal blocks: UAV 1 gets targets 2 and 3; nearest to (0, 0) is #2 (5, 6)
    assert r["targets_assigned"][-1] == 2
    assert r["cmd"][-1] == 2 and (r["sp_x"][-1], r["sp_y"][-1]) == (5.0, 6.0)
    assert r["mission_state"][-1] == 2


def test_fmu_uses_bundled_uavsim(built, tmp_path):
    """With the editable install of uavsim hidden, the FMU still runs from resources/uavsim."""
    code = textwrap.dedent(f"""
        import sys
        sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in repr(f)]
        try:
            import uavsim
            raise SystemExit("uavsim still importable outside the FMU")
        except ImportError:
            pass
        from fmpy import simulate_fmu
        simulate_fmu({str(built["UavDynamics"])!r}, stop_time=1.0, step_size=0.5)
        f = sys.modules["uavsim"].__file__
        assert "resources" in f, f
        print("OK", f)
    """)
    res = program_server.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                             timeout=120)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "OK" in res.stdout


def test_shipped_fmus_are_fresh():
    stale = bf.stale_fmus(REPO / "fmus", SRC)
    assert stale == [], f"stale FMUs {stale}: run `python fmu_sources/build_fmus.py`"


def test_stale_detection(tmp_path, built):
    src = tmp_path / "src"
    shutil.copytree(SRC, src, ignore=shutil.ignore_patterns("__pycache__"))
    fmus = built["UavDynamics"].parent
    assert bf.stale_fmus(fmus, src) == []
    (src / "uavsim" / "wind.py").write_text((src / "uavsim" / "wind.py").read_text() + "\n# edit\n")
    assert bf.stale_fmus(fmus, src) == [f"{n}.fmu" for n in bf.FMU_NAMES]
    (src / "UavBattery.py").write_text((src / "UavBattery.py").read_text() + "\n")
    (src / "uavsim" / "wind.py").write_text((SRC / "uavsim" / "wind.py").read_text())
    assert bf.stale_fmus(fmus, src) == ["UavBattery.fmu"]
    assert bf.stale_fmus(tmp_path / "nowhere", src) == [f"{n}.fmu" for n in bf.FMU_NAMES]


_shell = load_shell


@pytest.mark.parametrize("name", ["UavDynamics", "UavBattery", "UavWind", "UavStrategy"])
def test_fast_get_set_equal_pythonfmu(name):
    # uavsim.fmi.UnitsMixin replaces pythonfmu's get_*/set_* by table look-ups: same values, same errors;
    # pythonfmu's default accessor of a variable is the slave's attribute of that name, converted to the type
    from pythonfmu.variables import Boolean, Integer, Real, String
    s = _shell(name)
    s.exit_initialization_mode()
    s.do_step(0.0, 0.5)
    by_type = {t: [vr for vr, v in s.vars.items() if isinstance(v, t)] for t in (Real, Integer, Boolean, String)}
    conv = {Real: float, Integer: int, Boolean: bool, String: str}
    for t, fn in ((Real, "real"), (Integer, "integer"), (Boolean, "boolean"), (String, "string")):
        vrs = by_type[t]
        assert getattr(s, f"get_{fn}")(vrs) == [conv[t](getattr(s, s.vars[vr].name)) for vr in vrs]
        other = [vr for tt, lst in by_type.items() if tt is not t for vr in lst][:1]
        if other:
            with pytest.raises(TypeError):
                getattr(s, f"get_{fn}")(vrs[:1] + other)
            with pytest.raises(TypeError):
                getattr(s, f"set_{fn}")(other, [0])
    reals = [vr for vr in by_type[Real] if s.vars[vr].causality.name in ("input", "parameter")]
    s.set_real(reals, [float(i + 1) for i in range(len(reals))])
    assert [getattr(s, s.vars[vr].name) for vr in reals] == [float(i + 1) for i in range(len(reals))]


@pytest.mark.parametrize("name", ["UavDynamics", "UavBattery", "UavWind", "UavStrategy"])
def test_cosim_bind_equals_the_fmi_methods(name):
    # the in-process fast path (cosim_bind) reads what get_* returns and writes what set_* writes;
    # a request that get_*/set_* would refuse gets None (the master then calls the FMI method)
    from pythonfmu.variables import Integer, Real
    s = _shell(name)
    s.exit_initialization_mode()
    s.do_step(0.0, 0.5)
    for t, typ in ((Real, "Real"), (Integer, "Integer")):
        vrs = [vr for vr, v in s.vars.items() if isinstance(v, t)]
        assert s.cosim_bind("get", typ, vrs)() == getattr(s, f"get_{typ.lower()}")(vrs)
        settable = [vr for vr in vrs if s.vars[vr].causality.name in ("input", "parameter")]
        if settable:
            values = [float(i) + 0.5 if t is Real else i + 7 for i in range(len(settable))]
            s.cosim_bind("set", typ, settable)(values)
            assert getattr(s, f"get_{typ.lower()}")(settable) == values
    reals = [vr for vr, v in s.vars.items() if isinstance(v, Real)]
    ints = [vr for vr, v in s.vars.items() if isinstance(v, Integer)]
    if ints:
        assert s.cosim_bind("get", "Real", reals[:1] + ints[:1]) is None
    assert s.cosim_bind("get", "Real", [10 ** 6]) is None
    assert s.cosim_bind("frobnicate", "Real", reals) is None
    # the unconverted forms: get_raw fetches the same values (as stored in a buffer of the type), set_raw's
    # update writes what set_* writes; refused like the others
    import numpy as np
    for t, typ, dtype in ((Real, "Real", np.float64), (Integer, "Integer", np.int32)):
        vrs = [vr for vr, v in s.vars.items() if isinstance(v, t)]
        fetch, single = s.cosim_bind("get_raw", typ, vrs)
        buf = np.zeros(len(vrs), dtype=dtype)
        buf[:] = [fetch(s)] if single else fetch(s)
        assert buf.tolist() == getattr(s, f"get_{typ.lower()}")(vrs)
        settable = [vr for vr in vrs if s.vars[vr].causality.name in ("input", "parameter")]
        if settable:
            values = [float(i) + 0.25 if t is Real else i + 3 for i in range(len(settable))]
            update, names = s.cosim_bind("set_raw", typ, settable)
            update(zip(names, values))
            assert getattr(s, f"get_{typ.lower()}")(settable) == values
    if ints:
        assert s.cosim_bind("get_raw", "Real", reals[:1] + ints[:1]) is None
        assert s.cosim_bind("set_raw", "Integer", ints[:1] + reals[:1]) is None


def test_geodetic_outputs_follow_the_position():
    # lat/lon/alt are computed when read: after every step they equal the conversion of (x, y, z)
    from uavsim.geodesy import EnuFrame
    s = _shell("UavDynamics")
    s.exit_initialization_mode()
    names = {v.name: vr for vr, v in s.vars.items()}
    geo = [names["lat"], names["lon"], names["alt"]]
    frame = EnuFrame(s.origin_lat, s.origin_lon, s.origin_alt)
    s.cmd, s.sp_x, s.sp_y, s.sp_z = 2, 300.0, -120.0, 30.0
    for k in range(40):
        s.do_step(k * 1.0, 1.0)
        if k % 7 == 0:
            assert s.get_real(geo) == list(frame.to_geodetic(s.x, s.y, s.z))
    assert s.z > 20.0 and s.get_real(geo)[2] > s.origin_alt + 20.0
