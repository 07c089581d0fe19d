"""``cosim-master build-scenario`` dispatches to the scenario kind that claims the file."""
from master.cli import main


def test_build_scenario_of_a_file_no_kind_claims_is_a_one_line_error(tmp_path, capsys):
    src = tmp_path / "notes.txt"
    src.write_text("not a scenario")
    assert main(["build-scenario", str(src), "-o", str(tmp_path / "x.ssp")]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(src) in err and "no scenario kind claims this file" in err


def test_an_ssp_needs_no_building(tmp_path, capsys):
    src = tmp_path / "a.ssp"
    src.write_bytes(b"PK\x05\x06" + b"\0" * 18)
    assert main(["build-scenario", str(src), "-o", str(tmp_path / "b.ssp")]) == 1
    assert "nothing to build" in capsys.readouterr().err
