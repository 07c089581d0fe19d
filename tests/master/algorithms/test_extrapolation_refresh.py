"""What the extrapolation's refresh (``InputExtrapolation.refresh``: a feedthrough component's inputs set from the
new outputs and its outputs read again, with no doStep between) reads, by how the FMU computes its output.

FMI's co-simulation calling sequence does not allow that read (FMI 2.0 4.2.4; the docstring of ``refresh``):
an FMU whose getter evaluates its output from the inputs last set gives the consistent sample, one whose output
is fixed by its last doStep gives the doStep value again. Both expectations are written out by hand below for a
source I1 (x' = -x, x0 = 1, one explicit Euler step per doStep) feeding a gain G (k = 2) feeding I2, with
Jacobi and K = 1: G's input over step n is the step mean of I1.y, 3/2 y_n - 1/2 y_{n-1} (y_0 alone at n = 0)."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import master
from master.algorithms.extrapolation import InputExtrapolation
from master.ssp.writer import SspBuilder

K, H, STOP = 2.0, 0.1, 2.0

# y = k u computed in doStep from the input set before it (and at the end of initialization): a getter that
# returns what the last doStep left, whatever input was set since. pythonfmu writes no dependencies for y, which
# the master reads as "depends on every input", so G is refreshed.
HELD_GAIN = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class HeldGain(Fmi2Slave):
    author = "cosim-master tests"
    description = "y = k u, evaluated in doStep only"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.k = 1.0
        self.u = 0.0
        self.y = 0.0
        self.register_variable(Real("k", causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed))
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("y", causality=Fmi2Causality.output))

    def exit_initialization_mode(self):
        self.y = self.k * self.u

    def do_step(self, current_time, step_size):
        self.y = self.k * self.u
        return True
'''


@pytest.fixture(scope="module")
def held_gain(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("held_gain")
    (tmp / "HeldGain.py").write_text(HELD_GAIN)
    exe = Path(sys.executable).with_name("pythonfmu")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "pythonfmu"]
    proc = subprocess.run(cmd + ["build", "-f", "HeldGain.py", "-d", "out"], cwd=tmp, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return tmp / "out" / "HeldGain.fmu"


def _run(tmp_path, test_fmus, gain_fmu):
    b = SspBuilder("refresh", stop=STOP, step=H)
    b.add_component("I1", test_fmus["py:Integrator"], params={"a": -1.0, "x0": 1.0})
    b.add_component("G", gain_fmu, params={"k": K})
    b.add_component("I2", test_fmus["py:Integrator"])
    b.connect("I1", "y", "G", "u")
    b.connect("G", "y", "I2", "u")
    ssp = b.write(tmp_path / f"refresh_{gain_fmu.stem}.ssp")
    return master.run(ssp, output=None, record=["I1.y", "G.y", "I2.y"], algorithm="jacobi", extrapolation=1).frame


def _without_refresh(monkeypatch):
    monkeypatch.setattr(InputExtrapolation, "refresh", lambda self, t: None)


def test_a_getter_that_evaluates_gives_the_consistent_sample(tmp_path, test_fmus, monkeypatch):
    """Gain's getter is k u with the input last set: after the refresh G.y is k times I1.y at the same time."""
    df = _run(tmp_path, test_fmus, test_fmus["py:Gain"])
    y1, g = df["I1.y"].to_numpy(), df["G.y"].to_numpy()
    assert len(df) == round(STOP / H) + 1
    assert np.array_equal(g, K * y1)
    _without_refresh(monkeypatch)         # the check tells the two apart: read after the step alone, G.y lags
    lagging = _run(tmp_path, test_fmus, test_fmus["py:Gain"])["G.y"].to_numpy()
    assert not np.allclose(lagging[1:], K * y1[1:], rtol=1e-3)


def test_an_output_fixed_by_do_step_is_read_unchanged(tmp_path, test_fmus, held_gain, monkeypatch):
    """HeldGain's y is what its last doStep computed: the refresh reads that again (the run is bit for bit the
    run without it), which is k times the step mean G was given: a sample half a step off."""
    refreshed = []
    refresh = InputExtrapolation.refresh

    def noted(self, t):
        refreshed.append([self.rt.names[i] for i, _ in self.refreshed])
        refresh(self, t)
    monkeypatch.setattr(InputExtrapolation, "refresh", noted)
    df = _run(tmp_path, test_fmus, held_gain)
    assert refreshed == [["G"]] * (len(df) - 1)          # G was refreshed after every step
    monkeypatch.undo()
    y1, g = df["I1.y"].to_numpy(), df["G.y"].to_numpy()
    given = np.concatenate([[y1[0]], 1.5 * y1[1:-1] - 0.5 * y1[:-2]])     # G's input over steps 0 .. N-1
    np.testing.assert_allclose(g[1:], K * given, rtol=1e-14, atol=0)
    assert g[0] == K * y1[0]
    _without_refresh(monkeypatch)
    assert _run(tmp_path, test_fmus, held_gain).equals(df)
