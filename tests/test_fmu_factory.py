"""Each test FMU simulated alone with fmpy against hand-computed values."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
import zipfile

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2LastSuccessfulTime, fmi2Terminated
from fmpy.validation import validate_fmu

import fmu_factory
import program_server

ALL_KEYS = fmu_factory.available_keys()


def logger_collector():
    """An FMI 2 logger callback for simulate_fmu and the messages it got."""
    messages = []

    def logger(env, instance_name, status, category, message):
        messages.append((int(status), category.decode(), message.decode()))

    return logger, messages


# ---------------------------------------------------------------------------
# structure


def test_available_keys():
    expected = {
        "c2:MassA", "c2:MassB", "c2:Integrator", "c2:Gain", "c2:Faulty", "c3:Integrator", "me2:Oscillator",
        "py:MassA", "py:MassB", "py:Integrator", "py:Gain", "py:Faulty", "py:Types",
    }
    assert set(ALL_KEYS) == expected


def test_fixture_is_lazy_mapping(test_fmus):
    assert set(test_fmus) == set(ALL_KEYS)
    assert "c2:MassA" in test_fmus and "c9:Nope" not in test_fmus
    with pytest.raises(KeyError):
        test_fmus["c9:Nope"]
    assert test_fmus["c2:Gain"] is test_fmus["c2:Gain"]  # cached


@pytest.mark.parametrize("key", ALL_KEYS)
def test_builds_and_validates(test_fmus, key):
    path = test_fmus[key]
    assert path.exists() and path.suffix == ".fmu"
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    model = key.split(":")[1]
    assert md.modelName == model
    names = {v.name for v in md.modelVariables}
    with zipfile.ZipFile(path) as zf:
        files = set(zf.namelist())
    if key.startswith("c3"):
        assert md.fmiVersion == "3.0"
        assert f"binaries/x86_64-linux/{model}.so" in files
    else:
        assert md.fmiVersion == "2.0"
        assert f"binaries/linux64/{model}.so" in files
    expected_names = {
        "MassA": {"m", "k", "x0", "v0", "F", "x", "v"},
        "MassB": {"m", "k", "kc", "x0", "v0", "x_in", "x", "v", "F"},
        "Integrator": {"a", "x0", "u", "y"},
        "Gain": {"k", "u", "y"},
        "Oscillator": {"m", "k", "u", "x", "v", "der_x", "der_v"},
        "Faulty": {"fail_time", "mode", "y"},
        "Types": {"i_in", "i_out", "b_in", "b_out", "s_in", "s_out", "r_in", "r_out", "counter"},
    }[model]
    assert names - {"time"} == expected_names


def _deps(md):
    return {u.variable.name: sorted(d.name for d in u.dependencies) if u.dependencies is not None else None
            for u in md.outputs}


@pytest.mark.parametrize("family", ["c2", "py"])
def test_declared_output_dependencies(test_fmus, family):
    assert _deps(read_model_description(str(test_fmus[f"{family}:MassA"]))) == {"x": [], "v": []}
    assert _deps(read_model_description(str(test_fmus[f"{family}:MassB"]))) == {"x": [], "v": [], "F": ["x_in"]}
    assert _deps(read_model_description(str(test_fmus[f"{family}:Integrator"]))) == {"y": []}
    assert _deps(read_model_description(str(test_fmus[f"{family}:Gain"]))) == {"y": ["u"]}


def test_declared_dependencies_fmi3_and_me(test_fmus):
    assert _deps(read_model_description(str(test_fmus["c3:Integrator"]))) == {"y": []}
    md = read_model_description(str(test_fmus["me2:Oscillator"]))
    assert md.numberOfContinuousStates == 2 and md.numberOfEventIndicators == 0
    ders = {u.variable.name: sorted(d.name for d in u.dependencies) for u in md.derivatives}
    assert ders == {"der_x": ["v"], "der_v": ["u", "x"]}
    assert _deps(md) == {"x": ["x"], "v": ["v"]}


def _header_functions(header: str, prefix: str) -> set[str]:
    text = (fmu_factory.fmi_headers_dir() / header).read_text()
    return set(re.findall(rf"{prefix}_Export\s+\w+TYPE\s+(\w+)\s*;", text))


@pytest.mark.parametrize("key", ["c2:MassA", "me2:Oscillator", "c3:Integrator"])
def test_exports_every_api_function(test_fmus, key, tmp_path):
    version = 3 if key.startswith("c3") else 2
    required = _header_functions(f"fmi{version}Functions.h", f"FMI{version}")
    assert len(required) > 40
    model = key.split(":")[1]
    d = extract(str(test_fmus[key]), str(tmp_path))
    so = f"{d}/binaries/{'x86_64-linux' if version == 3 else 'linux64'}/{model}.so"
    out = subprocess.run(["nm", "-D", "--defined-only", so], capture_output=True, text=True, check=True).stdout
    exported = {line.split()[-1] for line in out.splitlines() if line.strip()}
    assert required <= exported, sorted(required - exported)
    # nothing but the FMI API is exported
    assert {s for s in exported if not s.startswith(f"fmi{version}")} == set()


# ---------------------------------------------------------------------------
# MassA / MassB


@pytest.mark.parametrize("family", ["c2", "py"])
def test_massA_free_is_cos(test_fmus, family):
    r = simulate_fmu(str(test_fmus[f"{family}:MassA"]), stop_time=2 * np.pi, output_interval=0.05)
    assert r["time"][0] == 0.0
    np.testing.assert_allclose(r["x"], np.cos(r["time"]), atol=1e-12)
    np.testing.assert_allclose(r["v"], -np.sin(r["time"]), atol=1e-12)


@pytest.mark.parametrize("family", ["c2", "py"])
def test_massA_constant_force_exact(test_fmus, family):
    m, k, F, x0, v0 = 2.0, 8.0, 4.0, 0.3, -1.0
    r = simulate_fmu(str(test_fmus[f"{family}:MassA"]), stop_time=3.0, output_interval=0.1,
                     start_values={"m": m, "k": k, "x0": x0, "v0": v0, "F": F})
    w, xe, t = np.sqrt(k / m), F / k, r["time"]
    np.testing.assert_allclose(r["x"], xe + (x0 - xe) * np.cos(w * t) + v0 / w * np.sin(w * t), atol=1e-12)
    np.testing.assert_allclose(r["v"], -(x0 - xe) * w * np.sin(w * t) + v0 * np.cos(w * t), atol=1e-12)


@pytest.mark.parametrize("family", ["c2", "py"])
def test_massA_without_spring(test_fmus, family):
    r = simulate_fmu(str(test_fmus[f"{family}:MassA"]), stop_time=1.0, output_interval=0.25,
                     start_values={"k": 0.0, "m": 2.0, "F": 1.0, "x0": 0.0, "v0": 1.0})
    t = r["time"]
    np.testing.assert_allclose(r["x"], t + 0.25 * t**2, atol=1e-14)


@pytest.mark.parametrize("family", ["c2", "py"])
def test_massB_held_input_exact(test_fmus, family):
    m, k, kc, x_in = 1.5, 1.0, 2.0, 0.8
    r = simulate_fmu(str(test_fmus[f"{family}:MassB"]), stop_time=2.0, output_interval=0.1,
                     start_values={"m": m, "k": k, "kc": kc, "x_in": x_in, "x0": 0.1})
    t = r["time"]
    w, xe = np.sqrt((k + kc) / m), kc * x_in / (k + kc)
    x = xe + (0.1 - xe) * np.cos(w * t)
    np.testing.assert_allclose(r["x"], x, atol=1e-12)
    np.testing.assert_allclose(r["F"], kc * (x - x_in), atol=1e-12)


def _slave(path, name="inst", logger=None):
    md = read_model_description(str(path))
    unzip = extract(str(path))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=name)
    if logger is None:
        slave.instantiate()
    else:
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                               fmi2CallbackLoggerTYPE, calloc, free)

        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(logger)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        slave._keep_callbacks = cb
        slave.instantiate(callbacks=cb, loggingOn=True)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return slave, vr


@pytest.mark.parametrize("family", ["c2", "py"])
def test_massB_feedthrough_is_immediate(test_fmus, family):
    s, vr = _slave(test_fmus[f"{family}:MassB"])
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setReal([vr["x0"], vr["kc"]], [0.5, 3.0])
    s.setReal([vr["x_in"]], [2.0])
    # during initialization the outputs already reflect x0 and the input
    assert s.getReal([vr["x"], vr["F"]]) == pytest.approx([0.5, 3.0 * (0.5 - 2.0)])
    s.exitInitializationMode()
    s.setReal([vr["x_in"]], [-1.0])
    assert s.getReal([vr["F"]])[0] == pytest.approx(3.0 * (0.5 + 1.0))  # no doStep needed
    s.terminate()
    s.freeInstance()


# ---------------------------------------------------------------------------
# Integrator / Gain


@pytest.mark.parametrize("key", ["c2:Integrator", "c3:Integrator", "py:Integrator"])
def test_integrator_constant_input(test_fmus, key):
    h, u, x0 = 0.1, 2.5, 1.0
    r = simulate_fmu(str(test_fmus[key]), stop_time=1.0, output_interval=h, start_values={"u": u, "x0": x0})
    n = np.round(r["time"] / h)
    np.testing.assert_allclose(r["y"], x0 + n * h * u, atol=1e-13)


@pytest.mark.parametrize("key", ["c2:Integrator", "c3:Integrator", "py:Integrator"])
def test_integrator_is_explicit_euler(test_fmus, key):
    h, a, u, x0 = 0.2, -1.5, 1.0, 2.0
    r = simulate_fmu(str(test_fmus[key]), stop_time=2.0, output_interval=h,
                     start_values={"a": a, "u": u, "x0": x0})
    x, expected = x0, [x0]
    for _ in range(len(r) - 1):
        x = x + h * (a * x + u)
        expected.append(x)
    np.testing.assert_allclose(r["y"], expected, rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize("family", ["c2", "py"])
def test_gain(test_fmus, family):
    s, vr = _slave(test_fmus[f"{family}:Gain"])
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setReal([vr["k"]], [-3.0])
    s.exitInitializationMode()
    for t, u in [(0.0, 1.0), (0.1, 2.0), (0.2, -0.5)]:
        s.setReal([vr["u"]], [u])
        assert s.getReal([vr["y"]])[0] == -3.0 * u  # feedthrough, before the step
        s.doStep(t, 0.1)
        assert s.getReal([vr["y"]])[0] == -3.0 * u
    s.terminate()
    s.freeInstance()


# ---------------------------------------------------------------------------
# Oscillator (Model Exchange)


def test_me_oscillator_cvode(test_fmus):
    r = simulate_fmu(str(test_fmus["me2:Oscillator"]), stop_time=2 * np.pi, output_interval=0.05,
                     relative_tolerance=1e-8)
    np.testing.assert_allclose(r["x"], np.cos(r["time"]), atol=1e-5)
    np.testing.assert_allclose(r["v"], -np.sin(r["time"]), atol=1e-5)


def test_me_oscillator_euler_exact_recurrence(test_fmus):
    h, m, k, u = 0.01, 2.0, 8.0, 1.0
    # fmpy's Euler solver takes one step per output interval
    r = simulate_fmu(str(test_fmus["me2:Oscillator"]), solver="Euler", step_size=h, output_interval=h,
                     stop_time=1.0, start_values={"m": m, "k": k, "u": u})
    z, expected = np.array([1.0, 0.0]), []
    for _ in range(len(r)):
        expected.append(z.copy())
        z = z + h * np.array([z[1], (-k * z[0] + u) / m])
    expected = np.array(expected)
    np.testing.assert_allclose(r["x"], expected[:, 0], atol=1e-12)
    np.testing.assert_allclose(r["v"], expected[:, 1], atol=1e-12)
    # and the Euler solution is close to the exact one
    w, xe = np.sqrt(k / m), u / k
    np.testing.assert_allclose(r["x"], xe + (1 - xe) * np.cos(w * r["time"]), atol=0.03)


# ---------------------------------------------------------------------------
# Types (pythonfmu)


def test_types_all_fmi2_types(test_fmus):
    r = simulate_fmu(str(test_fmus["py:Types"]), stop_time=0.3, output_interval=0.1,
                     start_values={"i_in": 41, "b_in": True, "s_in": "abc", "r_in": 1.25},
                     output=["i_out", "b_out", "r_out", "counter"])
    assert list(r["i_out"]) == [42] * 4
    assert list(r["b_out"]) == [False] * 4
    assert list(r["r_out"]) == [2.5] * 4
    assert list(r["counter"]) == [0, 1, 2, 3]
    s, vr = _slave(test_fmus["py:Types"])
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    assert s.getString([vr["s_out"]]) == [b"hello!"]
    s.setString([vr["s_in"]], ["xyz"])
    s.setBoolean([vr["b_in"]], [False])
    s.setInteger([vr["i_in"]], [-5])
    assert s.getString([vr["s_out"]]) == [b"xyz!"]
    assert s.getBoolean([vr["b_out"]]) == [True]
    assert s.getInteger([vr["i_out"]]) == [-4]
    s.doStep(0.0, 0.1)
    assert s.getInteger([vr["counter"]]) == [1]
    s.terminate()
    s.freeInstance()
    md = read_model_description(str(test_fmus["py:Types"]))
    types = {v.name: v.type for v in md.modelVariables}
    assert types == {"i_in": "Integer", "i_out": "Integer", "b_in": "Boolean", "b_out": "Boolean",
                     "s_in": "String", "s_out": "String", "r_in": "Real", "r_out": "Real", "counter": "Integer"}


# ---------------------------------------------------------------------------
# Faulty and error reporting


def test_faulty_c_mode0_never_fails(test_fmus):
    r = simulate_fmu(str(test_fmus["c2:Faulty"]), stop_time=1.0, output_interval=0.1, start_values={"mode": 0})
    np.testing.assert_allclose(r["y"], r["time"], atol=1e-14)
    assert r["time"][-1] == pytest.approx(1.0)


def test_faulty_c_error_is_logged(test_fmus):
    logger, messages = logger_collector()
    with pytest.raises(FMICallException) as exc:
        simulate_fmu(str(test_fmus["c2:Faulty"]), stop_time=1.0, output_interval=0.1,
                     start_values={"mode": 1, "fail_time": 0.35}, logger=logger)
    assert exc.value.status == 3  # fmi2Error
    errors = [m for m in messages if m[0] == 3]
    assert errors and "injected error" in errors[0][2] and errors[0][1] == "logStatusError"


def test_faulty_c_discard(test_fmus):
    s, vr = _slave(test_fmus["c2:Faulty"], logger=lambda *a: None)
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setInteger([vr["mode"]], [2])
    s.exitInitializationMode()
    t = 0.0
    for _ in range(5):
        s.doStep(t, 0.1)
        t += 0.1
    assert s.getBooleanStatus(fmi2Terminated) is False or s.getBooleanStatus(fmi2Terminated) == 0
    with pytest.raises(FMICallException) as exc:
        s.doStep(t, 0.1)
    assert exc.value.status == 2  # fmi2Discard
    assert s.getBooleanStatus(fmi2Terminated)
    assert s.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(0.5)
    assert s.getReal([vr["y"]])[0] == pytest.approx(0.5)
    s.terminate()
    s.freeInstance()


def test_c_fmu_logs_api_misuse(test_fmus):
    messages = []
    s, vr = _slave(test_fmus["c2:Gain"], logger=lambda env, name, st, cat, msg: messages.append((st, msg)))
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    with pytest.raises(FMICallException):
        s.setReal([vr["y"]], [1.0])  # output
    with pytest.raises(FMICallException):
        s.setReal([vr["k"]], [1.0])  # fixed parameter after initialization
    with pytest.raises(FMICallException):
        s.getReal([99])
    with pytest.raises(FMICallException):
        s.doStep(0.5, 0.1)  # wrong communication point
    with pytest.raises(FMICallException):
        s.getFMUstate()
    assert len([m for m in messages if m[0] == 3]) == 5
    s.terminate()
    s.freeInstance()


_CRASH_SCRIPT = textwrap.dedent(
    """
    import sys
    from fmpy import simulate_fmu
    simulate_fmu(sys.argv[1], stop_time=1.0, output_interval=0.1, start_values={"mode": 3})
    print("survived")
    """
)


@pytest.mark.parametrize("key", ["c2:Faulty", "py:Faulty"])
def test_faulty_crash_mode_aborts_process(test_fmus, key):
    proc = program_server.run([sys.executable, "-c", _CRASH_SCRIPT, str(test_fmus[key])],
                              capture_output=True, text=True, timeout=120)
    assert proc.returncode != 0
    assert proc.returncode == -6  # SIGABRT
    assert "survived" not in proc.stdout


_EXCEPTION_SCRIPT = textwrap.dedent(
    """
    import sys
    from fmpy import read_model_description, extract
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi1 import FMICallException
    md = read_model_description(sys.argv[1])
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(sys.argv[1]),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="f")
    s.instantiate(callbacks=None)
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setInteger([vr["mode"]], [1])
    s.exitInitializationMode()
    try:
        for i in range(10):
            s.doStep(0.1 * i, 0.1)
    except FMICallException as exc:
        print("status", exc.status, "step", i)
    """
)


def test_faulty_python_modes(test_fmus):
    # mode 1: an exception in do_step -> pythonfmu reports fmi2Fatal. Run in a child process: pythonfmu 0.7's
    # binary over-releases a Python object on that path and the interpreter crashes later in garbage collection.
    proc = program_server.run([sys.executable, "-c", _EXCEPTION_SCRIPT, str(test_fmus["py:Faulty"])],
                              capture_output=True, text=True, timeout=120)
    assert "status 4 step 5" in proc.stdout, proc.stdout + proc.stderr
    # mode 2: do_step returns False -> fmi2Discard with Terminated = true
    s, vr = _slave(test_fmus["py:Faulty"], logger=lambda *a: None)
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setInteger([vr["mode"]], [2])
    s.setReal([vr["fail_time"]], [0.2])
    s.exitInitializationMode()
    s.doStep(0.0, 0.1)
    s.doStep(0.1, 0.1)
    with pytest.raises(FMICallException) as exc:
        s.doStep(0.2, 0.1)
    assert exc.value.status == 2
    assert s.getBooleanStatus(fmi2Terminated)
    assert s.getReal([vr["y"]])[0] == pytest.approx(0.2)
    s.terminate()
    s.freeInstance()


# ---------------------------------------------------------------------------
# C and Python twins agree


@pytest.mark.parametrize("model,start", [
    ("MassA", {"F": 0.7, "m": 1.3, "k": 2.1, "x0": -0.4, "v0": 0.9}),
    ("MassB", {"x_in": 0.4, "kc": 2.5, "x0": 1.0}),
    ("Integrator", {"a": -0.3, "u": 0.2, "x0": 3.0}),
    ("Gain", {"u": 1.5, "k": 4.0}),
])
def test_c_and_python_twins_agree(test_fmus, model, start):
    rc = simulate_fmu(str(test_fmus[f"c2:{model}"]), stop_time=1.0, output_interval=0.1, start_values=start)
    rp = simulate_fmu(str(test_fmus[f"py:{model}"]), stop_time=1.0, output_interval=0.1, start_values=start)
    assert rc.dtype.names == rp.dtype.names
    for name in rc.dtype.names:
        np.testing.assert_allclose(rc[name], rp[name], rtol=1e-13, atol=1e-14)
