"""The scripting API a notebook uses: values by name (``Execution.get``/``set``), the time from construction,
observers added at any point, the rows recorded so far, no output folder unless asked, and systems built in code
(``SspBuilder``) run from memory or written as an SSP. Expectations are closed forms (a mass on a spring, which
MassA integrates exactly for a held force) or an independent run of the same system."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

import master
from master.errors import CosimError, ScenarioError
from master.observers.base import Observer
from master.ssp.writer import SspBuilder

ROOT = Path(__file__).resolve().parents[2]
COUPLING = ROOT / "ssp" / "coupling"
MASS_A, MASS_B = COUPLING / "fmus" / "MassA.fmu", COUPLING / "fmus" / "MassB.fmu"
OSC = COUPLING / "oscillator_fd.ssp"


def spring(t, m, k, x0, v0, force):
    """m x'' = -k x + F with F held: (x, v) at t."""
    w, xe = math.sqrt(k / m), force / k
    return (xe + (x0 - xe) * math.cos(w * t) + v0 / w * math.sin(w * t),
            -(x0 - xe) * w * math.sin(w * t) + v0 * math.cos(w * t))


def one_mass(**params) -> SspBuilder:
    b = SspBuilder("one_mass", stop=4.0, step=0.01)
    return b.add_component("A", MASS_A, params={"m": 2.0, "k": 0.5, "x0": 1.0, "v0": 0.0, **params})


@pytest.fixture(autouse=True)
def _nothing_in_the_working_directory(tmp_path, monkeypatch):
    """Every test runs in an empty folder and leaves it so: the API writes no file unless told where."""
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    yield
    assert list(cwd.iterdir()) == []


# ------------------------------------------------------------------------------------------------ values by name
def test_values_read_by_name_follow_the_closed_form_and_a_set_input_changes_the_motion():
    with master.Execution(one_mass()) as ex:
        assert ex.get("A.F") == 0.0 and ex.get(["A.m", "A.k"]) == [2.0, 0.5]      # start values, before anything
        ex.initialize()
        ex.simulate_until(1.0)
        x1, v1 = ex.get(["A.x", "A.v"])
        assert (x1, v1) == pytest.approx(spring(1.0, 2.0, 0.5, 1.0, 0.0, 0.0), abs=1e-12)
        ex.set("A.F", 0.25)                                  # an unconnected input, between two steps
        ex.simulate_until(3.0)
        assert ex.time == pytest.approx(3.0)
        assert ex.get(["A.x", "A.v"]) == pytest.approx(spring(2.0, 2.0, 0.5, x1, v1, 0.25), abs=1e-12)
        assert ex.get("A.F") == 0.25


def test_a_start_value_set_before_initialize_is_the_one_the_run_starts_from():
    ex = master.Execution(one_mass())
    ex.set("A.x0", 3.0)
    ex.set("A.v0", -1)                                       # an int for a Real: converted, as with --param
    assert ex.get(["A.x0", "A.v0"]) == [3.0, -1.0]
    ex.simulate_until(2.0)
    assert ex.get("A.x") == pytest.approx(spring(2.0, 2.0, 0.5, 3.0, -1.0, 0.0)[0], abs=1e-12)
    meta = ex.close()
    assert meta["parameters_overridden"] == {"A.x0": 3.0, "A.v0": -1}


def test_a_variable_only_recorded_is_read_fresh_not_from_the_last_sample():
    """A.v and B.v feed no connection: recorded once a second, the master's slots for them hold the last
    sample; get reads them at every step as a run recording every step has them."""
    every_step = master.run(OSC, stop_time=0.2, record=["A.v", "B.v"]).frame.set_index("time")
    with master.Execution(OSC, stop_time=0.2, record=["A.v", "B.v"], record_interval=1.0) as ex:
        ex.initialize()
        for _ in range(20):
            t = ex.step()
            row = every_step.loc[every_step.index[round(t / 0.01)]]
            assert ex.get(["A.v", "B.v"]) == [row["A.v"], row["B.v"]]


def test_unknown_names_are_one_line_errors_naming_the_closest():
    ex = master.Execution(OSC)
    with pytest.raises(CosimError) as e:
        ex.get("A.xx")
    assert str(e.value) == "get A.xx: component 'A' has no variable 'xx'; close: A.x, A.x0"
    with pytest.raises(CosimError, match=r"^set C\.x: no component of 'C\.x' is in the system \(components: A, B\)"):
        ex.set("C.x", 1.0)
    with pytest.raises(CosimError, match=r"^get AA\.x: .*; close: A\.x"):
        ex.get("AA.x")


def test_what_fmi_forbids_to_set_is_refused_naming_the_variable_and_why():
    with master.Execution(OSC) as ex:
        with pytest.raises(CosimError, match=r"^set A\.x: cannot set it before initialize\(\): .*causality output"):
            ex.set("A.x", 1.0)
        with pytest.raises(CosimError, match=r"not a valid Float64|not a valid Real"):
            ex.set("A.m", "heavy")
        ex.initialize()
        with pytest.raises(CosimError, match=r"^set A\.F: A\.F is driven by a connection"):
            ex.set("A.F", 1.0)
        with pytest.raises(CosimError, match=r"^set A\.m: .*not an input or a tunable parameter .*variability fixed"):
            ex.set("A.m", 2.0)
        with pytest.raises(CosimError, match=r"^set A\.x: .*causality output"):
            ex.set("A.x", 2.0)


def test_get_after_close_says_the_fmus_are_gone():
    ex = master.Execution(one_mass())
    ex.simulate_until(0.1)
    ex.close()
    with pytest.raises(CosimError, match="closed"):
        ex.get("A.x")


# ------------------------------------------------------------------------------------------ time, observers, rows
def test_time_and_stop_time_are_known_from_construction():
    ex = master.Execution(OSC, stop_time=2.0)
    assert (ex.time, ex.stop_time, ex.done) == (0.0, 2.0, False)
    ex.close()


class Peak(Observer):
    """The largest value of a variable seen after a step (through the observer interface: by position in a
    buffer)."""
    def __init__(self, name="A.x"):
        self.name, self.peak, self.steps = name, -math.inf, 0

    def required_variables(self):
        return [self.name]

    def attach(self, ctx, start):
        super().attach(ctx, start)
        typ, self.pos = ctx.position(self.name)
        self.buf = ctx.buffer(typ)

    def after_step(self, n, t0, t1):
        self.steps += 1
        self.peak = max(self.peak, float(self.buf[self.pos]))


def test_observers_join_before_or_after_initialize():
    early = Peak()
    with master.Execution(one_mass()) as ex:
        ex.add_observer(early)
        ex.initialize()
        ex.simulate_until(1.0)
        with pytest.raises(CosimError, match=r"^add_observer: A\.v is not read every step"):
            ex.add_observer(Peak("A.v"))    # nothing reads A.v here: only an observer given before initialize could
        also = Peak("A.x")                  # the early observer's variable is
        ex.add_observer(also)
        ex.simulate_until(2.0)
    assert also.steps == 100 and also.peak == pytest.approx(spring(1.01, 2.0, 0.5, 1.0, 0.0, 0.0)[0], abs=1e-12)
    assert early.steps == 200 and early.peak == pytest.approx(spring(0.01, 2.0, 0.5, 1.0, 0.0, 0.0)[0], abs=1e-12)
    late = Peak()
    with master.Execution(OSC, stop_time=2.0) as ex:      # here A.x feeds B: read every step
        ex.simulate_until(1.0)
        ex.add_observer(late)
        ex.simulate_until()
    assert late.steps == 100


def test_rows_recorded_so_far_are_there_during_the_run():
    with master.Execution(one_mass(), record=["A.x"]) as ex:
        assert ex.memory_table() is None                    # nothing recorded before initialize
        ex.initialize()
        assert ex.memory_table().num_rows == 1              # the first sample
        ex.simulate_until(0.5)
        table = ex.memory_table()
        assert table.num_rows == 51 and table.column("time").to_pylist()[-1] == pytest.approx(0.5)
        assert table.column("A.x").to_pylist()[-1] == ex.get("A.x")
        ex.simulate_until()
    assert ex.memory_table().num_rows == 401


# ------------------------------------------------------------------------------------------------- no folder
def test_the_api_writes_no_output_folder_unless_asked(tmp_path):
    r = master.run(OSC, stop_time=0.1)
    assert r.output_dir is None and len(r.frame) == 11
    out = tmp_path / "out"
    r = master.run(OSC, stop_time=0.1, output=out)
    assert r.output_dir == out and (out / "results.parquet").is_file()


def test_the_cli_keeps_its_default_folder(tmp_path):
    from master.cli import main
    assert main(["run", str(OSC), "--stop-time", "0.1", "--no-supervise"]) == 0
    made = Path("results") / "oscillator_fd"
    assert (made / "results.parquet").is_file()
    import shutil
    shutil.rmtree("results")         # the autouse fixture wants the working directory empty again


# ------------------------------------------------------------------------------------------ systems built in code
def two_masses() -> SspBuilder:
    """oscillator_fd.ssp, built in code."""
    b = SspBuilder("osc", stop=1.0, step=0.01, algorithm="jacobi")
    b.add_component("A", MASS_A, params={"m": 1.0, "k": 1.0, "x0": 1.0, "v0": 0.0})
    b.add_component("B", MASS_B, params={"m": 1.0, "k": 1.0, "kc": 1.0, "x0": 0.0, "v0": 0.0})
    return b.connect("A.x", "B.x_in").connect("B.F", "A.F")


def test_a_system_built_in_code_runs_from_memory_and_as_the_ssp_it_writes(tmp_path):
    b = two_masses()
    in_memory = master.run(b, record=["A.x", "B.x"]).frame
    ssp = b.write(tmp_path / "osc.ssp")
    from_file = master.run(ssp, record=["A.x", "B.x"]).frame
    shipped = master.run(OSC, stop_time=1.0, algorithm="jacobi", record=["A.x", "B.x"]).frame
    assert in_memory.equals(from_file) and in_memory.equals(shipped)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cwd", "osc.ssp"]


def test_a_connection_by_name_is_checked_against_the_components_added():
    b = SspBuilder("x").add_component("A", MASS_A)
    with pytest.raises(ScenarioError, match=r"^connect A\.xv: component 'A' has no output connector 'xv'; close: A\.x"):
        b.connect("A.xv", "A.F")
    with pytest.raises(ScenarioError, match=r"^connect B\.x_in: no component of 'B\.x_in' has been added"):
        b.connect("A.x", "B.x_in")
    assert b.connections == []


# ------------------------------------------------------------------------------------------------------ types
EXTREMES = {"Int8": -128, "UInt8": 255, "Int16": -32768, "UInt16": 65535, "Int32": -2**31, "UInt32": 2**32 - 1,
            "Int64": -2**63, "UInt64": 2**64 - 1}


@pytest.mark.parametrize("fmi", ["fmi2", "fmi3"])
def test_every_type_is_set_and_read_back_by_name(reference_fmus, fmi):
    """The Reference Feedthrough copies each input to its output in its step: what is set is what comes back,
    as the Python value of its type (FMI 3: every integer width at its extremes, Float32, Binary)."""
    b = SspBuilder("types", stop=1.0, step=0.5).add_component("m", reference_fmus / fmi / "Feedthrough.fmu")
    if fmi == "fmi2":
        given = {"Float64_continuous_input": 0.1, "Int32_input": -2**31, "Boolean_input": True,
                 "String_input": "set by name"}
        starts = {"Boolean_input": False, "String_input": "Set me!", "Int32_input": 0}
    else:
        given = {"Float64_continuous_input": 0.1, "Float32_continuous_input": 0.5, "Boolean_input": True,
                 "String_input": "set by name", "Binary_input": b"\x00\xffbar",
                 **{f"{t}_input": v for t, v in EXTREMES.items()}}
        starts = {"Boolean_input": False, "String_input": "Set me!", "Binary_input": b"foo", "UInt64_input": 0}
    with master.Execution(b) as ex:
        assert ex.get([f"m.{n}" for n in starts]) == list(starts.values())
        for name, value in given.items():
            assert type(ex.get(f"m.{name}")) is type(value), name
        ex.initialize()
        for name, value in given.items():
            ex.set(f"m.{name}", value)
        ex.step()
        for name, value in given.items():
            got = ex.get(f"m.{name.replace('_input', '_output')}")
            assert got == value and type(got) is type(value), name
