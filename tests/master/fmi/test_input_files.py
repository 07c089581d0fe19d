"""Input signals from a file: an SSD component of type text/csv (OMSimulator's convention) and ``run --input`` (the
FMI cross-check ``_in.csv`` format). Expectations are the FMI cross-check rules, computed here from the CSV:
a continuous Real input interpolates linearly between rows, any other holds the last row at or before t; before
the first row the first value, after the last the last."""
import csv

import numpy as np
import pandas as pd
import pytest

import fmu_factory
import master
from cli_in_process import run_cli
from fmu_factory import CModel, Var
from master.cli import main
from master.errors import ScenarioError
from master.ssp.writer import SspBuilder

from ssd_text import component, connection, connector, experiment, settings, ssd, write_folder

TABLE = '<ssd:Component name="table" type="text/csv" source="resources/{csv}">\n<ssd:Connectors>\n{cons}' \
        '</ssd:Connectors>\n</ssd:Component>\n'
# the Feedthrough outputs the cross-check input file leaves alone: their inputs keep their start values
UNDRIVEN = ("Float32_continuous_output", "Float32_discrete_output", "Float64_continuous_output",
            "Float64_discrete_output", "Boolean_output", "Enumeration_output")


def _table(csv_name: str, columns, typ="Real") -> str:
    return TABLE.format(csv=csv_name, cons="".join(connector(c, "output", typ) for c in columns))


def _read_in_csv(path):
    """The cross-check input file as text: times and each column's cells."""
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return [float(r[0]) for r in rows[1:]], {name: [r[k] for r in rows[1:]] for k, name in enumerate(rows[0]) if k}


def _held(times, cells, t):
    """The FMI cross-check rule for a discrete input: the last row at or before t (the first before it)."""
    at_or_before = [k for k, row_t in enumerate(times) if row_t <= t + 1e-12]
    return cells[at_or_before[-1] if at_or_before else 0]


def _feedthrough_by_table(tmp_path, reference_fmus, version, driven):
    """Feedthrough (FMI ``version``) with an input table of Feedthrough_in.csv whose columns ``driven`` drive the
    inputs of the same names; every column is declared, as OMSimulator declares a table."""
    ref = reference_fmus / "ref" / "Feedthrough_in.csv"
    _, cells = _read_in_csv(ref)
    elements = (_table("Feedthrough_in.csv", cells, "Integer")
                + component("m", "resources/Feedthrough.fmu", "".join(connector(c, "input", "Integer") for c in driven)))
    conns = "".join(connection("table", c, "m", c) for c in driven)
    xml = ssd("table", elements, conns, experiment_xml=experiment(2.0, settings(0.1, "gauss-seidel")))
    return write_folder(tmp_path / "table", xml, {"Feedthrough.fmu": reference_fmus / version / "Feedthrough.fmu",
                                                  "Feedthrough_in.csv": ref})


def _feedthrough_ssp(tmp_path, reference_fmus, version):
    b = SspBuilder("feedthrough", stop=2.0, step=0.1, algorithm="gauss-seidel")
    b.add_component("m", reference_fmus / version / "Feedthrough.fmu")
    return b.write(tmp_path / "feedthrough.ssp")


def _within_cross_check_band(got: pd.DataFrame, ref: pd.DataFrame, columns):
    for col in columns:
        want = ref[col].to_numpy(dtype=float)
        values = np.interp(ref["time"].to_numpy(), got["time"].to_numpy(), got[f"m.{col}"].to_numpy(dtype=float))
        band = 0.1 * max(np.ptp(want), 1e-12)
        assert np.max(np.abs(values - want)) <= band, col


def _run_feedthrough(tmp_path, reference_fmus, version, how):
    """The run's frame and the input columns the file drove."""
    _, cells = _read_in_csv(reference_fmus / "ref" / "Feedthrough_in.csv")
    if how == "--input":
        inputs = reference_fmus / "ref" / "Feedthrough_in.csv"
        r = master.run(_feedthrough_ssp(tmp_path, reference_fmus, version), output=None, inputs=inputs,
                       record=["m.*"])
        return r.frame, list(cells)
    driven = list(cells) if version == "fmi3" else ["Int32_input"]       # FMI 2.0's Feedthrough has Int32 only
    r = master.run(_feedthrough_by_table(tmp_path, reference_fmus, version, driven), output=None, record=["m.*"])
    return r.frame, driven


@pytest.mark.parametrize("version,how", [("fmi2", "table"), ("fmi3", "table"), ("fmi3", "--input")])
def test_feedthrough_driven_by_the_cross_check_input_file(tmp_path, reference_fmus, version, how):
    frame, driven = _run_feedthrough(tmp_path, reference_fmus, version, how)
    times, cells = _read_in_csv(reference_fmus / "ref" / "Feedthrough_in.csv")
    ref = pd.read_csv(reference_fmus / "ref" / "Feedthrough_out.csv")
    # integer inputs are discrete: held at the row at or before t, every bit kept (the Int64/UInt64 extremes);
    # gauss-seidel steps the table first, so the feedthrough output at t shows the input at t
    for column in driven:
        output = f"m.{column.replace('_input', '_output')}"
        assert [str(x) for x in frame[output]] == [_held(times, cells[column], t) for t in frame["time"]], output
    # what the file does not drive is as in the reference results, within the cross-check band
    present = [c for c in UNDRIVEN if f"m.{c}" in frame]
    assert {"Float64_continuous_output", "Float64_discrete_output"} <= set(present)
    _within_cross_check_band(frame, ref, present)
    if version == "fmi3":
        assert set(frame["m.String_output"]) == set(ref["String_output"])
        assert {x.hex() for x in frame["m.Binary_output"]} == set(ref["Binary_output"])


def test_an_input_file_column_that_names_no_input_is_refused(tmp_path, reference_fmus):
    ssp = _feedthrough_ssp(tmp_path, reference_fmus, "fmi2")     # FMI 2.0's Feedthrough has no Int8_input
    with pytest.raises(ScenarioError, match="7 columns name no input of m: 'Int8_input', .*Int32_input.*--lenient"):
        master.run(ssp, output=None, inputs=reference_fmus / "ref" / "Feedthrough_in.csv")


def test_a_misspelt_input_column_is_refused_with_the_near_miss(tmp_path, reference_fmus):
    ssp = _feedthrough_ssp(tmp_path, reference_fmus, "fmi2")
    (tmp_path / "in.csv").write_text("time,Int32_inpt\n0,1\n")
    with pytest.raises(ScenarioError, match="'Int32_inpt' \\(did you mean 'Int32_input'\\?\\).*--lenient"):
        master.run(ssp, output=None, inputs=tmp_path / "in.csv")


def test_lenient_ignores_the_columns_that_name_no_input_and_says_which(tmp_path, reference_fmus):
    """The one Feedthrough_in.csv of the Reference FMUs drives the FMI 2.0 Feedthrough too (from the command line:
    the warning reaches the terminal of a supervised run)."""
    out = tmp_path / "out"
    r = run_cli(["run", str(_feedthrough_ssp(tmp_path, reference_fmus, "fmi2")), "-o", str(out), "--input",
                 str(reference_fmus / "ref" / "Feedthrough_in.csv"), "--lenient", "--record", "m.Int32_output"],
                cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "ignoring columns Int8_input, UInt8_input, Int16_input, UInt16_input, UInt32_input, Int64_input, " \
           "UInt64_input" in r.stderr
    with open(out / "results.csv", newline="") as fh:
        column = [row["m.Int32_output"] for row in csv.DictReader(fh)]
    assert column[-1] == "2147483647"


def test_the_command_line_input_option(tmp_path, reference_fmus):
    out = tmp_path / "out"
    assert main(["run", str(_feedthrough_ssp(tmp_path, reference_fmus, "fmi3")), "-o", str(out), "--input",
                 str(reference_fmus / "ref" / "Feedthrough_in.csv"), "--record", "m.UInt64_output"]) == 0
    with open(out / "results.csv", newline="") as fh:
        column = [row["m.UInt64_output"] for row in csv.DictReader(fh)]
    assert column == ["0"] * 10 + ["18446744073709551615"] * 11


# -- linear and hold by hand, with C test FMUs -------------------------------------------------------------------

# the rows: a first row after the start, a step at t = 1 (two rows of one time: the later holds from then), and
# a last row before the stop
SIGNAL = "time,ramp,held\n0.5,4,4\n1,10,10\n1,20,20\n2,0,0\n"
TIMES = [0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5]
LINEAR = [4.0, 4.0, 4.0, 7.0, 20.0, 15.0, 10.0, 5.0, 0.0, 0.0, 0.0]
HOLD = [4.0, 4.0, 4.0, 4.0, 20.0, 20.0, 20.0, 20.0, 0.0, 0.0, 0.0]


@pytest.fixture(scope="module")
def gains(tmp_path_factory, test_fmus):
    """Gain (y = k u, u a continuous input) and the same equations with u a discrete input."""
    gain = fmu_factory.C_MODELS["Gain"]
    discrete = [Var(v.name, v.type, v.causality, "discrete" if v.causality != "parameter" else v.variability,
                    v.initial, v.start, v.description) for v in gain.variables]
    fmu_factory.VARIANT_MODELS.setdefault("GainDiscrete", CModel(
        "GainDiscrete", "y = k u with a discrete input", discrete, gain.output_deps, {(2, "cs")}, source="Gain.c"))
    return test_fmus["c2:Gain"], fmu_factory.build_c_fmu("GainDiscrete", tmp_path_factory.mktemp("gains"))


def _gain_table_scenario(tmp_path, gains, links, algorithm="gauss-seidel"):
    u_y = connector("u", "input") + connector("y", "output")
    elements = (_table("signal.csv", ["ramp", "held"]) + component("cont", "resources/Gain.fmu", u_y)
                + component("disc", "resources/GainDiscrete.fmu", u_y))
    conns = "".join(connection("table", col, comp, "u") for col, comp in links)
    xml = ssd("gains", elements, conns, experiment_xml=experiment(2.5, settings(0.25, algorithm)))
    return write_folder(tmp_path / "gains", xml, {"Gain.fmu": gains[0], "GainDiscrete.fmu": gains[1]},
                        {"resources/signal.csv": SIGNAL})


def test_linear_for_a_continuous_input_and_hold_for_a_discrete_one(tmp_path, gains):
    folder = _gain_table_scenario(tmp_path, gains, [("ramp", "cont"), ("held", "disc")])
    frame = master.run(folder, output=None, record=["cont.y", "disc.y"]).frame
    assert frame["time"].tolist() == pytest.approx(TIMES)
    assert frame["cont.y"].tolist() == pytest.approx(LINEAR)
    assert frame["disc.y"].tolist() == pytest.approx(HOLD)


def test_with_jacobi_an_input_reaches_the_output_one_step_later(tmp_path, gains):
    folder = _gain_table_scenario(tmp_path, gains, [("ramp", "cont"), ("held", "disc")], algorithm="jacobi")
    frame = master.run(folder, output=None, record=["table.*", "cont.y", "disc.y"]).frame
    assert frame["table.ramp"].tolist() == pytest.approx(LINEAR)
    assert frame["table.held"].tolist() == pytest.approx(HOLD)
    assert frame["cont.y"].tolist() == pytest.approx(LINEAR[:1] + LINEAR[:-1])
    assert frame["disc.y"].tolist() == pytest.approx(HOLD[:1] + HOLD[:-1])


def test_one_column_for_inputs_of_two_variabilities_is_refused(tmp_path, gains):
    folder = _gain_table_scenario(tmp_path, gains, [("ramp", "cont"), ("ramp", "disc")])
    with pytest.raises(ScenarioError, match="column 'ramp' drives cont.u .* and disc.u .*own column"):
        master.run(folder, output=None)


@pytest.mark.parametrize("text,why", [("t,u\n0,1\n", "first column must be 'time'"),
                                      ("time,ramp,held\n1,2,3\n0,1,1\n", "must not decrease"),
                                      ("time,ramp,held\n0,x,1\n", "'x' in column 'ramp' is not a valid Real"),
                                      ("time,ramp,held\n0,1\n", "2 fields where the header has 3")])
def test_a_malformed_table_is_refused_with_the_reason(tmp_path, gains, text, why):
    folder = _gain_table_scenario(tmp_path, gains, [("ramp", "cont"), ("held", "disc")])
    (folder / "resources" / "signal.csv").write_text(text)
    with pytest.raises(ScenarioError, match=why):
        master.run(folder, output=None)
