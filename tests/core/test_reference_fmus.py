"""The Modelica Reference FMUs (the FMI standard's own test models) run as one-component SSPs from their
default experiments, against the reference results shipped with them, by the FMI cross-check rule: every
signal within 10 % of its range of the reference at the reference's time points."""
import numpy as np
import pandas as pd
import pytest

import master
from master.ssp.writer import SspBuilder

# (model, versions, why not run here) -- the rest run as co-simulation with no option at all
CASES = [("BouncingBall", ("fmi2", "fmi3"), None), ("Dahlquist", ("fmi2", "fmi3"), None),
         ("VanDerPol", ("fmi2", "fmi3"), None), ("Resource", ("fmi2", "fmi3"), None)]


def _cross_check(df: pd.DataFrame, ref: pd.DataFrame, name: str):
    t = df["time"].to_numpy()
    for col in ref.columns[1:]:
        want = ref[col].to_numpy(dtype=float)
        got = np.interp(ref["time"].to_numpy(), t, df[f"{name}.{col}"].to_numpy(dtype=float))
        band = 0.1 * max(np.ptp(want), 1e-12) + 1e-9 * np.max(np.abs(want))
        worst = np.max(np.abs(got - want))
        assert worst <= band, f"{col}: off by {worst:g}, band {band:g}"


@pytest.mark.parametrize("model,version", [(m, v) for m, vs, _ in CASES for v in vs])
def test_reference_fmu_as_co_simulation(tmp_path, reference_fmus, model, version):
    fmu = reference_fmus / version / f"{model}.fmu"
    ref = pd.read_csv(reference_fmus / "ref" / f"{model}_out.csv")
    b = SspBuilder(model.lower(), stop=None, step=None)
    b.add_component(model.lower(), fmu)
    ssp = b.write(tmp_path / f"{model}.ssp")
    # no stop time or step anywhere but in the FMU: its default experiment (Resource has no step size:
    # (stop - start) / 500, as fmpy)
    r = master.run(ssp, output=None, record=[f"{model.lower()}.*"])
    assert r.metadata["settings_sources"]["stop"] == "FMU DefaultExperiment"
    _cross_check(r.frame, ref, model.lower())
