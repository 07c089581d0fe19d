"""FMI 3.0 Binary variables end to end, with the Reference FMU Feedthrough (Binary_input -> Binary_output, start
value 666f6f, "foo"): a declared but unconnected Binary connector, our own SSP writer's output, recording (Parquet
binary, CSV lowercase hex as the reference results write it), patterns, FMU-to-FMU connections and --param."""
import csv

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import master
from master.cli import main
from master.errors import ScenarioError
from master.ssp.writer import SspBuilder

from ssd_text import component, connection, connector, experiment, settings, ssd, write_folder


def _reference_binary_output(reference_fmus) -> list[str]:
    """The Binary_output column of the reference results: what any FMI importer records (hex text)."""
    with open(reference_fmus / "ref" / "Feedthrough_out.csv", newline="") as fh:
        return [row["Binary_output"] for row in csv.DictReader(fh)]


def _csv_column(path, name) -> list[str]:
    with open(path, newline="") as fh:
        return [row[name] for row in csv.DictReader(fh)]


def _written_by_us(tmp_path, reference_fmus):
    """Feedthrough as our SSP writer declares it: every input and output a connector, nothing connected."""
    b = SspBuilder("feedthrough", stop=0.3, step=0.1)
    b.add_component("m", reference_fmus / "fmi3" / "Feedthrough.fmu")
    return b.write(tmp_path / "feedthrough.ssp")


def test_a_declared_unconnected_binary_connector_is_accepted(tmp_path, reference_fmus):
    elements = component("m", "resources/Feedthrough.fmu", connector("Binary_input", "input", "Binary")
                         + connector("Binary_output", "output", "Binary"))
    folder = write_folder(tmp_path / "declared", ssd("declared", elements, experiment_xml=experiment(0.2, settings(0.1))),
                          {"Feedthrough.fmu": reference_fmus / "fmi3" / "Feedthrough.fmu"})
    r = master.run(folder, output=None, record=["m.Binary_output"])
    assert r.frame["m.Binary_output"].tolist() == [b"foo"] * 3


def test_our_writers_ssp_runs_and_records_binary_as_the_reference_results(tmp_path, reference_fmus):
    ssp = _written_by_us(tmp_path, reference_fmus)
    out = tmp_path / "out"
    master.run(ssp, output=out, record=["m.*"])
    table = pq.read_table(out / "results.parquet")
    assert table.schema.field("m.Binary_output").type == pa.binary()
    assert table.column("m.Binary_output").to_pylist() == [b"foo"] * 4
    want = _reference_binary_output(reference_fmus)[0]                # "666f6f"
    assert _csv_column(out / "results.csv", "m.Binary_output") == [want] * 4
    assert {"m.Binary_input", "m.Binary_output", "m.String_output"} <= set(table.column_names)


def test_binary_goes_through_the_supervised_command_line_run(tmp_path, reference_fmus):
    ssp = _written_by_us(tmp_path, reference_fmus)
    out = tmp_path / "out"
    assert main(["run", str(ssp), "-o", str(out), "--record", "m.Binary*", "--record", "m.String_output",
                 "--param", "m.Binary_input=00FF10"]) == 0
    assert _csv_column(out / "results.csv", "m.Binary_output") == ["00ff10"] * 4
    assert _csv_column(out / "results.csv", "m.String_output") == ["Set me!"] * 4
    assert pq.read_table(out / "results.parquet").column("m.Binary_input").to_pylist() == [b"\x00\xff\x10"] * 4


def test_a_binary_connection_moves_the_bytes_from_fmu_to_fmu(tmp_path, reference_fmus):
    cons = connector("Binary_input", "input", "Binary") + connector("Binary_output", "output", "Binary")
    elements = component("a", "resources/Feedthrough.fmu", cons) + component("b", "resources/Feedthrough.fmu", cons)
    xml = ssd("pair", elements, connection("a", "Binary_output", "b", "Binary_input"),
              experiment_xml=experiment(0.2, settings(0.1, "gauss-seidel")))
    folder = write_folder(tmp_path / "pair", xml, {"Feedthrough.fmu": reference_fmus / "fmi3" / "Feedthrough.fmu"})
    # high and low bytes, an embedded and a trailing zero byte (Feedthrough holds up to 128 bytes)
    payload = bytes(range(0, 256, 4)) + b"\x00tail\x00"
    r = master.run(folder, output=None, params={"a.Binary_input": payload.hex()}, record=["b.Binary_output"])
    assert r.frame["b.Binary_output"].tolist() == [payload] * 3


def test_a_binary_value_that_is_not_hexadecimal_is_refused(tmp_path, reference_fmus):
    with pytest.raises(ScenarioError, match="'zz' is not a valid Binary"):
        master.run(_written_by_us(tmp_path, reference_fmus), output=None, params={"m.Binary_input": "zz"})


def test_a_binary_parameter_value_of_an_ssv_is_given_as_hex(tmp_path, reference_fmus):
    b = SspBuilder("feedthrough", stop=0.1, step=0.1)
    b.add_component("m", reference_fmus / "fmi3" / "Feedthrough.fmu", params={"Binary_input": b"\x01\x02"},
                    ssv=True)
    r = master.run(b.write(tmp_path / "ssv.ssp"), output=None, record=["m.Binary_output"])
    assert r.frame["m.Binary_output"].tolist() == [b"\x01\x02"] * 2
