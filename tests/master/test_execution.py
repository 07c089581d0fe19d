"""The stepping API (Execution): stepping from Python equals a whole run, rollback through FMU states,
manipulators between steps, and extension points (a new algorithm, a new sink) each added in one file --
here, this test module -- through the registries."""
import json

import sys
from pathlib import Path
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import master
from master.algorithms import ALGORITHMS
from master.algorithms.base import Algorithm
from master.cli import main
from master.errors import CosimError
from master.execution import Execution
from master.manipulators import Manipulator
from master.observers import Observer
from master.sinks import SINKS
from master.sinks.base import Sink
from master.ssp.writer import SspBuilder
sys.path.insert(0, str(Path(__file__).resolve().parent / "algorithms"))   # test_algorithms' chain, wherever
# this file is collected from
from test_algorithms import _chain as chain_ssp


def _chain(tmp_path, test_fmus, h=0.05, k=-2.0, a1=-0.3, a2=0.2):
    """I1 -> G -> I2 -> I1 over 2 s (test_algorithms' chain, whose closed forms are derived there)."""
    return chain_ssp(tmp_path, test_fmus, h, k, a1, a2)


REC = ["I1.y", "G.y", "I2.y"]


def test_stepping_from_python_equals_a_whole_run(tmp_path, test_fmus):
    ssp = _chain(tmp_path, test_fmus)
    whole = master.run(ssp, output=None, record=REC).frame
    with Execution(ssp, output=tmp_path / "stepped", record=REC) as ex:
        ex.initialize()
        assert ex.time == 0.0 and ex.n == 0
        for k in range(1, 6):
            assert ex.step() == pytest.approx(0.05 * k, abs=1e-15)
        assert ex.simulate_until(0.5) == pytest.approx(0.5)
        assert ex.simulate_until(0.52) == pytest.approx(0.55)     # a time between steps: the next step's end
        assert ex.simulate_until(0.3) == pytest.approx(0.55)      # the past is not revisited
        ex.simulate_until()
        assert ex.done and ex.n == 40
        with pytest.raises(CosimError, match="no further step"):
            ex.step()
    meta = json.loads((tmp_path / "stepped" / "run.json").read_text())
    assert meta["outcome"] == "completed" and meta["steps_done"] == 40 and meta["rows_recorded"] == 41
    stepped = pq.read_table(tmp_path / "stepped" / "results.parquet").to_pandas()
    assert stepped.equals(whole)


def test_closing_early_keeps_what_was_recorded(tmp_path, test_fmus):
    ssp = _chain(tmp_path, test_fmus)
    ex = Execution(ssp, output=tmp_path / "out", record=REC)
    ex.simulate_until(0.25)
    meta = ex.close()
    assert meta["outcome"] == "error" and meta["steps_done"] == 5      # not "completed": the stop time was 2
    df = pq.read_table(tmp_path / "out" / "results.parquet").to_pandas()
    np.testing.assert_allclose(df["time"], 0.05 * np.arange(6), atol=1e-15)


# -- a new algorithm in one file: Gauss-Seidel in reverse declaration order ---------------------------------
@ALGORITHMS.register("test-reverse-gs")
class ReverseGaussSeidel(Algorithm):
    gauss_seidel = True

    def stepping_order(self, rt, plan):
        self.info = {"order": list(reversed(rt.names))}
        return list(reversed(range(len(rt.names))))


def test_a_new_algorithm_is_known_to_api_cli_and_annotation(tmp_path, test_fmus):
    h, k, a1, a2 = 0.05, -2.0, -0.3, 0.2
    ssp = _chain(tmp_path, test_fmus, h, k, a1, a2)
    df = master.run(ssp, output=None, algorithm="test-reverse-gs", record=REC).frame
    # order I2, G, I1: x2' = (1+h a2) x2 + h g;  g' = k x1;  x1' = (1+h a1) x1 + h x2'   (state x1, g, x2)
    J = np.array([[1 + h * a1, h * h, h * (1 + h * a2)], [k, 0, 0], [0, h, 1 + h * a2]])
    s, expected = np.array([1.0, k, 0.5]), []
    for _ in range(len(df)):
        expected.append(s)
        s = J @ s
    np.testing.assert_allclose(df[REC].to_numpy(), np.array(expected), rtol=1e-13, atol=1e-15)
    assert main(["run", str(ssp), "--algorithm", "test-reverse-gs", "-o", str(tmp_path / "cli"),
                 "--record", "I*.y"]) == 0
    meta = json.loads((tmp_path / "cli" / "run.json").read_text())
    assert meta["algorithm"] == "test-reverse-gs" and meta["algorithm_info"]["order"] == ["I2", "G", "I1"]
    with pytest.raises(CosimError, match="unknown algorithm 'nope'.*test-reverse-gs"):
        master.run(ssp, output=None, algorithm="nope")


# -- a new sink in one file: JSON lines ---------------------------------------------------------------------
@SINKS.register("test-jsonl")
class JsonLinesSink(Sink):
    def open(self, out_dir, schema):
        super().open(out_dir, schema)
        self.path = out_dir / "results.jsonl"
        self.fh = open(self.path, "w", encoding="utf-8")

    def write(self, block: pa.Table):
        for row in block.to_pylist():
            self.fh.write(json.dumps(row) + "\n")

    def close(self):
        self.fh.close()

    def files(self):
        return [self.path]


def test_a_new_sink_receives_every_recorded_row(tmp_path, test_fmus):
    ssp = _chain(tmp_path, test_fmus)
    master.run(ssp, output=tmp_path / "out", record=REC, sinks=["parquet", "test-jsonl"], record_interval=0.1)
    rows = [json.loads(line) for line in (tmp_path / "out" / "results.jsonl").read_text().splitlines()]
    table = pq.read_table(tmp_path / "out" / "results.parquet").to_pylist()
    assert len(rows) == 21 and rows == table          # JSON round-trips doubles exactly
    assert not (tmp_path / "out" / "results.csv").exists()
    with pytest.raises(CosimError, match="unknown sink 'xml'"):
        master.run(ssp, output=tmp_path / "bad", sinks=["xml"])


# -- manipulators -------------------------------------------------------------------------------------------
class StepInput(Manipulator):
    """Sets ``target`` to ``value`` before the step that starts at ``at``."""

    def __init__(self, target, value, at):
        self.target, self.value, self.at = target, value, at

    def before_step(self, n, t):
        if abs(t - self.at) < 1e-12:
            self.ctx.set_value(self.target, self.value)


def test_a_manipulator_changes_an_unconnected_input_between_steps(tmp_path, test_fmus):
    b = SspBuilder("one", stop=1.0, step=0.1)
    b.add_component("I", test_fmus["c2:Integrator"], params={"a": 0.0, "x0": 0.0})
    ssp = b.write(tmp_path / "one.ssp")
    df = master.run(ssp, output=None, record=["I.y"], manipulators=[StepInput("I.u", 2.0, 0.5)]).frame
    # y' = u, explicit Euler: 0 until t = 0.5, then 2 (t - 0.5)
    np.testing.assert_allclose(df["I.y"], np.maximum(0.0, 2.0 * (df["time"] - 0.5)), atol=1e-12)
    with pytest.raises(CosimError, match="driven by a connection"):
        master.run(_chain(tmp_path, test_fmus), output=None, manipulators=[StepInput("I1.u", 2.0, 0.5)])


# -- rollback through FMU states -----------------------------------------------------------------------------
class Trace(Observer):
    def __init__(self, var):
        self.var, self.rows = var, []

    def required_variables(self):
        return [self.var]

    def attach(self, ctx, start):
        super().attach(ctx, start)
        typ, self.pos = ctx.position(self.var)
        self.buf = ctx.buffer(typ)

    def after_step(self, n, t0, t1):
        self.rows.append((t1, float(self.buf[self.pos])))


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_rollback_repeats_the_same_steps_bit_for_bit(tmp_path, reference_fmus, version):
    b = SspBuilder("vdp", stop=3.0, step=0.1)
    b.add_component("vdp", reference_fmus / version / "VanDerPol.fmu")
    ssp = b.write(tmp_path / f"vdp_{version}.ssp")
    trace = Trace("vdp.x0")
    with Execution(ssp, output=None, observers=[trace]) as ex:
        ex.check_state_support()
        ex.simulate_until(1.0)
        saved = ex.save_state()
        ex.simulate_until(2.0)
        first = trace.rows[10:]
        ex.restore_state(saved)
        assert ex.time == pytest.approx(1.0) and ex.n == 10
        ex.simulate_until(2.0)
        again = trace.rows[20:]
        ex.release_state(saved)
    assert len(first) == 10 and again == first
    # and the trajectory is the van der Pol oscillator's: x0 starts at 2 and swings below 0 within ~1.5 s
    assert trace.rows[0][1] < 2.0 and min(v for _, v in first) < 1.5


def test_rollback_is_refused_before_it_is_needed_for_an_fmu_without_state(tmp_path, test_fmus):
    with Execution(_chain(tmp_path, test_fmus), output=None) as ex:
        with pytest.raises(CosimError, match="components I1, G, I2 cannot save and restore their state"):
            ex.check_state_support()
