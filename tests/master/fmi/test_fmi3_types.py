"""FMI 3.0 integer widths and arrays end to end, with FMUs from another tool (the Modelica Reference FMUs):
values set, connected FMU to FMU and recorded come back exactly; StateSpace's arrays match its reference CSV."""
import csv

import numpy as np
import pyarrow.parquet as pq
import pytest

import master
from master.errors import ScenarioError
from master.supervise import run_supervised

from ssd_text import component, connection, connector, experiment, settings, ssd, write_folder

# the extremes of each FMI 3.0 integer type that did not fit the int32 buffers
EXTREMES = {"UInt32": [2**32 - 1, 2**31], "Int64": [2**63 - 1, -2**63], "UInt64": [2**64 - 1, 2**63]}
WIDE = tuple(EXTREMES)


def _feedthrough_pair(tmp_path, reference_fmus, types=WIDE, links=None):
    """a (Feedthrough) -> b (Feedthrough): a.<T>_output -> b.<T>_input for each type, or the given links."""
    links = links or [(t, t) for t in types]
    cons = "".join(connector(f"{t}_input", "input", "Integer") + connector(f"{t}_output", "output", "Integer")
                   for t in types)
    elements = component("a", "resources/Feedthrough.fmu", cons) + component("b", "resources/Feedthrough.fmu", cons)
    conns = "".join(connection("a", f"{s}_output", "b", f"{d}_input") for s, d in links)
    xml = ssd("widths", elements, conns, experiment_xml=experiment(0.2, settings(0.1)))
    return write_folder(tmp_path / "widths", xml, {"Feedthrough.fmu": reference_fmus / "fmi3" / "Feedthrough.fmu"})


def _csv_columns(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return {name: [row[k] for row in rows[1:]] for k, name in enumerate(rows[0])}


@pytest.mark.parametrize("pick", [0, 1])
@pytest.mark.parametrize("supervised", [False, True])
def test_wide_integers_keep_every_bit_through_connections_and_recording(tmp_path, reference_fmus, pick,
                                                                         supervised):
    values = {t: EXTREMES[t][pick] for t in WIDE}
    folder = _feedthrough_pair(tmp_path, reference_fmus)
    params = {f"a.{t}_input": str(v) for t, v in values.items()}     # as --param gives them
    out = tmp_path / "out"
    (run_supervised if supervised else master.run)(folder, output=out, params=params, record=["*_output"])
    table = pq.read_table(out / "results.parquet")
    columns = _csv_columns(out / "results.csv")
    for t, v in values.items():
        for comp in "ab":
            name = f"{comp}.{t}_output"
            assert str(table.schema.field(name).type) == t.lower()
            assert table.column(name).to_pylist() == [v] * 3, name
            assert columns[name] == [str(v)] * 3, name


def test_narrow_integers_get_columns_of_their_own_width(tmp_path, reference_fmus):
    narrow = {"Int8": -128, "UInt8": 255, "Int16": -32768, "UInt16": 65535, "Int32": -2**31}
    folder = _feedthrough_pair(tmp_path, reference_fmus, types=tuple(narrow))
    r = master.run(folder, output=tmp_path / "out", params={f"a.{t}_input": v for t, v in narrow.items()},
                   record=["b.*_output"])
    table = pq.read_table(tmp_path / "out" / "results.parquet")
    for t, v in narrow.items():
        assert str(table.schema.field(f"b.{t}_output").type) == t.lower()
        assert table.column(f"b.{t}_output").to_pylist() == [v] * 3
    assert r.ok


@pytest.mark.parametrize("typ, value", [("UInt32", 2**32), ("UInt32", -1), ("Int64", 2**63), ("UInt64", 2**64),
                                        ("UInt64", -1)])
def test_a_value_out_of_the_type_range_is_refused(tmp_path, reference_fmus, typ, value):
    folder = _feedthrough_pair(tmp_path, reference_fmus)
    with pytest.raises(ScenarioError, match=f"out of range for a.{typ}_input"):
        master.run(folder, output=None, params={f"a.{typ}_input": str(value)})


@pytest.mark.parametrize("src, dst, why", [
    ("Int64", "Int32", "not every Int64 value"),       # narrowing: values would be cut to their low bits
    ("Int64", "UInt64", "not every Int64 value"),      # negative values
    ("Int32", "Int64", "change width"),                # fits, but travels in another buffer
])
def test_connections_between_integer_widths_are_refused_with_the_reason(tmp_path, reference_fmus, src, dst, why):
    folder = _feedthrough_pair(tmp_path, reference_fmus, types=("Int32", "Int64", "UInt64"), links=[(src, dst)])
    with pytest.raises(ScenarioError, match=why):
        master.run(folder, output=None)


def test_widening_inside_one_buffer_is_allowed(tmp_path, reference_fmus):
    folder = _feedthrough_pair(tmp_path, reference_fmus, types=("UInt16", "Int32", "UInt32", "Int64"),
                               links=[("UInt16", "Int32"), ("UInt32", "Int64")])
    r = master.run(folder, output=None, params={"a.UInt16_input": 65535, "a.UInt32_input": 2**32 - 1},
                   record=["b.*_output"])
    assert list(r.frame["b.Int32_output"]) == [65535] * 3
    assert list(r.frame["b.Int64_output"]) == [2**32 - 1] * 3
    assert np.all(r.frame["time"] >= 0)


# ------------------------------------------------------------------------------------------------ arrays
def _reference(reference_fmus, name):
    """The reference CSV: time, then each array output as one column of space-separated elements."""
    with open(reference_fmus / "ref" / f"{name}_out.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    return np.array([float(r[0]) for r in rows[1:]]), np.array([[float(x) for x in r[1].split()] for r in rows[1:]])


def _state_space(tmp_path, reference_fmus, elements, conns="", name="ss"):
    # StateSpace's default experiment (0..10 s) with its fixed internal step, the reference's output interval
    xml = ssd(name, elements, conns, experiment_xml=experiment(10.0, settings(1.0)))
    return write_folder(tmp_path / name, xml, {"StateSpace.fmu": reference_fmus / "fmi3" / "StateSpace.fmu"})


def test_state_space_arrays_match_the_reference_results(tmp_path, reference_fmus):
    t_ref, y_ref = _reference(reference_fmus, "StateSpace")
    folder = _state_space(tmp_path, reference_fmus, component("m", "resources/StateSpace.fmu",
                                                               connector("u", "input") + connector("y", "output")))
    r = master.run(folder, output=tmp_path / "out", record=["m.y*"])
    df = r.frame
    assert list(df.columns) == ["time", "m.y[1]", "m.y[2]", "m.y[3]"]
    np.testing.assert_array_equal(df["time"], t_ref)
    # exact, which is stricter than the cross-check rule (10 % of the signal's range)
    np.testing.assert_array_equal(df[["m.y[1]", "m.y[2]", "m.y[3]"]].to_numpy(), y_ref)
    assert _csv_columns(tmp_path / "out" / "results.csv")["m.y[3]"][1] == repr(float(y_ref[1, 2]))


def test_array_elements_and_whole_arrays_connect_and_take_parameters(tmp_path, reference_fmus):
    # a.y = a.u e^t-ish (A = B = C = D = I); b.u[1] <- a.y[2], b.u[2] and b.u[3] keep their values (5, and 3 from
    # the modelDescription); c.u <- b.y as a whole. With D = I each y is its u at t = 0, so the first row reads
    # through every connection (Jacobi at t = 0 after initialization's propagation).
    cons = connector("u", "input") + connector("y", "output")
    elements = "".join(component(c, "resources/StateSpace.fmu", cons) for c in "abc")
    conns = (connection("a", "y[2]", "b", "u[1]") + connection("b", "y", "c", "u"))
    folder = _state_space(tmp_path, reference_fmus, elements, conns)
    r = master.run(folder, output=None, record=["*.y*", "b.u[2]"],
                   params={"a.u": "10 20 30", "b.u[2]": "5"}, stop_time=1.0)
    first = r.frame.iloc[0]
    assert [first[f"a.y[{k}]"] for k in (1, 2, 3)] == [10.0, 20.0, 30.0]
    assert [first[f"b.y[{k}]"] for k in (1, 2, 3)] == [20.0, 5.0, 3.0]
    assert [first[f"c.y[{k}]"] for k in (1, 2, 3)] == [20.0, 5.0, 3.0]
    assert first["b.u[2]"] == 5.0


@pytest.mark.parametrize("params, why", [
    ({"m.n": "2"}, "structural parameter giving the size of"),
    ({"m.u": "1 2"}, "has 3 elements"),
])
def test_array_values_that_cannot_apply_are_refused(tmp_path, reference_fmus, params, why):
    folder = _state_space(tmp_path, reference_fmus, component("m", "resources/StateSpace.fmu",
                                                               connector("u", "input") + connector("y", "output")))
    with pytest.raises(ScenarioError, match=why):
        master.run(folder, output=None, params=params)


def test_an_array_connected_to_a_scalar_is_refused(tmp_path, reference_fmus):
    cons = connector("u", "input") + connector("y", "output")
    elements = "".join(component(c, "resources/StateSpace.fmu", cons) for c in "ab")
    folder = _state_space(tmp_path, reference_fmus, elements, connection("a", "y", "b", "u[1]"))
    with pytest.raises(ScenarioError, match="two arrays of the same shape"):
        master.run(folder, output=None)
