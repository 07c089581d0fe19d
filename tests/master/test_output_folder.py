"""A run owns its output folder: an earlier run's products are replaced as a whole (nothing stale is left
beside the new results), and a folder of someone else's files is refused untouched."""
import json

import pytest

import master
from master.errors import CosimError
from master.observers import Observer
from master.ssp.writer import SspBuilder


class EmitOnce(Observer):
    def after_step(self, n, t0, t1):
        if n == 0:
            self.ctx.emit({"time": t1, "type": "mark"})


def _ssp(tmp_path, test_fmus):
    b = SspBuilder("one", stop=0.5, step=0.1)
    b.add_component("I", test_fmus["c2:Integrator"], params={"a": 0.0, "x0": 1.0})
    return b.write(tmp_path / "one.ssp")


def test_a_rerun_replaces_the_earlier_runs_products_as_a_whole(tmp_path, test_fmus):
    out = tmp_path / "out"
    master.run(_ssp(tmp_path, test_fmus), output=out, record=["I.y"], observers=[EmitOnce()])
    first = json.loads((out / "run.json").read_text())["products"]
    assert {"events.csv", "results.parquet", "results.csv", "fmu.log", "run.json"} <= set(first)
    (out / "my_notes.txt").write_text("kept")          # not a product of the run: stays
    master.run(_ssp(tmp_path, test_fmus), output=out, record=["I.y"], write_csv=False)
    second = json.loads((out / "run.json").read_text())["products"]
    assert not (out / "events.csv").exists() and not (out / "results.csv").exists()   # stale ones gone
    assert "events.csv" not in second and (out / "my_notes.txt").read_text() == "kept"


def test_a_folder_of_other_files_is_refused_untouched(tmp_path, test_fmus):
    out = tmp_path / "theirs"
    out.mkdir()
    (out / "thesis.tex").write_text("precious")
    with pytest.raises(CosimError, match="not empty and holds no earlier run"):
        master.run(_ssp(tmp_path, test_fmus), output=out)
    assert sorted(p.name for p in out.iterdir()) == ["thesis.tex"]
    from master.supervise import run_supervised
    with pytest.raises(CosimError, match="not empty and holds no earlier run"):
        run_supervised(_ssp(tmp_path, test_fmus), output=out)
    assert sorted(p.name for p in out.iterdir()) == ["thesis.tex"]
