"""Steps and accuracy of adaptive communication steps and ECCO against fixed steps (docs/coupling.md tables).

    .venv/bin/python bench/bench_adaptive_steps.py          # about a minute on a 2-core machine

Prints one table per system: for each setting the accepted steps (rejected), doStep calls and the largest
deviation from the closed form over the record grid; for fixed steps also the step count a fixed step needs
for the adaptive run's error, from the measured first- or second-order law of the fixed-step runs.
"""
from __future__ import annotations

import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import fmu_factory  # noqa: E402
from analytic import chain_exact, two_mass_energy, two_mass_exact  # noqa: E402

import master  # noqa: E402
from master.ssp.power_bonds import power_bonds_annotation  # noqa: E402
from master.ssp.writer import SspBuilder  # noqa: E402

STOP = 10.0


def build_fmus(where: Path) -> dict:
    variants = {
        "IntegratorRollback": dataclasses.replace(fmu_factory.C_MODELS["Integrator"], name="IntegratorRollback",
                                                  source="Integrator.c", saves_state=True,
                                                  versions_kinds={(2, "cs")}),
        "MassBBond": dataclasses.replace(fmu_factory.C_MODELS["MassB"], name="MassBBond", source="MassB.c",
                                         variables=fmu_factory.C_MODELS["MassB"].variables
                                         + [fmu_factory._input("v_in", 0.0, "velocity of mass 1")]),
    }
    for name, spec in variants.items():
        fmu_factory.VARIANT_MODELS.setdefault(name, spec)
    return {m: fmu_factory.build_c_fmu(m, where) for m in ("IntegratorRollback", "MassA", "MassB", "MassBBond")}


def chain(fmus, where, h):
    b = SspBuilder("chain", stop=STOP, step=h)
    b.add_component("I1", fmus["IntegratorRollback"], params={"a": -20.0, "x0": 1.0})
    b.add_component("I2", fmus["IntegratorRollback"], params={"a": -0.5, "x0": 0.0})
    b.connect("I2", "y", "I1", "u")
    b.connect("I1", "y", "I2", "u")
    return b.write(where / f"chain_{h}.ssp"), ["I1.y", "I2.y"]


def chain_error(df):
    x1, x2 = chain_exact(df["time"].to_numpy(), -20.0, -0.5, 1.0, 1.0, 0.0)
    return max(np.max(np.abs(df["I1.y"] - x1)), np.max(np.abs(df["I2.y"] - x2)))


def masses(fmus, where, h, bond=False):
    b = SspBuilder("osc", stop=STOP, step=h)
    b.add_component("A", fmus["MassA"], params={"x0": 1.0})
    b.add_component("B", fmus["MassBBond" if bond else "MassB"])
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    if bond:
        b.connect("A", "v", "B", "v_in")
        b.annotations.append(power_bonds_annotation([("spring", ("B", "F", "A", "F"), ("A", "v", "B", "v_in"))]))
    return b.write(where / f"osc_{h}_{bond}.ssp"), ["A.x", "A.v", "B.x", "B.v"]


def masses_error(df):
    x1, _, x2, _ = two_mass_exact(df["time"].to_numpy())
    return max(np.max(np.abs(df["A.x"] - x1)), np.max(np.abs(df["B.x"] - x2)))


def energy_drift(df):
    e = two_mass_energy(df["A.x"], df["A.v"], df["B.x"], df["B.v"])
    return float(np.max(np.abs(e - e[0])))


def row(label, ssp_record, error, **options):
    ssp, record = ssp_record
    r = master.run(ssp, output=None, record=record, **options)
    info = r.metadata.get("algorithm_info", {})
    steps = info.get("steps", r.metadata["steps"])
    return label, steps, info.get("rejected", 0), info.get("fmu_calls", 2 * steps), error(r.frame), r.frame


def fixed_law(h, error, order):
    """c in error = c h^order, from the finest fixed step measured."""
    return error / h**order


def table(title, rows, law=None, order=1):
    print(f"\n{title}\n")
    print("| setting | steps (rejected) | doStep calls | max error | fixed steps for that error |")
    print("|---|---|---|---|---|")
    for label, steps, rejected, calls, error, _ in rows:
        need = f"{STOP / (error / law) ** (1 / order):,.0f}" if law and not label.startswith("jacobi") else ""
        print(f"| {label} | {steps} ({rejected}) | {calls} | {error:.2e} | {need} |")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp)
        fmus = build_fmus(where)
        fixed = [row(f"jacobi h = {h}", chain(fmus, where, h), chain_error, algorithm="jacobi")
                 for h in (0.005, 0.0025, 0.00125)]
        law = fixed_law(0.00125, fixed[-1][4], 1)
        adaptive = [row(f"adaptive K=0 rtol {tol:g}", chain(fmus, where, 0.5), chain_error, algorithm="adaptive",
                        step_rtol=tol) for tol in (1e-2, 1e-3)]
        adaptive += [row("adaptive K=0 doubling rtol 1e-5", chain(fmus, where, 0.5), chain_error,
                         algorithm="adaptive", step_rtol=1e-5, error_estimate="doubling")]
        table("chain x1' = -20 x1 + x2, x2' = -0.5 x2 + x1 (explicit Euler FMUs), 0..10 s", fixed + adaptive, law, 1)

        fixed = [row(f"jacobi K=1 h = {h}", masses(fmus, where, h), masses_error, algorithm="jacobi",
                     extrapolation=1) for h in (0.02, 0.01)]
        law = fixed_law(0.01, fixed[-1][4], 2)
        adaptive = [row(f"adaptive K=1 rtol {tol:g}", masses(fmus, where, 0.5), masses_error, algorithm="adaptive",
                        step_rtol=tol, extrapolation=1) for tol in (1e-3, 1e-4)]
        table("two-mass oscillator, 0..10 s, master step 0.5, K = 1", fixed + adaptive, law, 2)
        fixed = [row("jacobi K=0 h = 0.01", masses(fmus, where, 0.01), masses_error, algorithm="jacobi")]
        law = fixed_law(0.01, fixed[-1][4], 1)
        adaptive = [row(f"adaptive K=0 rtol {tol:g}", masses(fmus, where, 0.5), masses_error, algorithm="adaptive",
                        step_rtol=tol) for tol in (1e-2, 1e-3)]
        table("two-mass oscillator, 0..10 s, master step 0.5, K = 0", fixed + adaptive, law, 1)

        print("\nECCO on the two-mass oscillator (bond B.F -> A.F, A.v -> B.v_in), 0..10 s, master step 0.5\n")
        print("| rtol | ecco steps | energy drift | max error | median eps | jacobi, as many equal steps: drift | "
              "max error |")
        print("|---|---|---|---|---|---|---|")
        for tol in (1e-2, 1e-3, 1e-4):
            ssp, record = masses(fmus, where, 0.5, bond=True)
            r = master.run(ssp, output=where / f"ecco_{tol}", record=record, algorithm="ecco", step_rtol=tol)
            eps = np.loadtxt(where / f"ecco_{tol}" / "steps.csv", delimiter=",", skiprows=1, usecols=2)
            n = r.metadata["algorithm_info"]["steps"]
            *_, error, df = row("", masses(fmus, where, STOP / n, bond=True), masses_error, algorithm="jacobi")
            print(f"| {tol:g} | {n} | {energy_drift(r.frame):.3f} | {masses_error(r.frame):.3f} | "
                  f"{np.median(eps):.2f} | {energy_drift(df):.3f} | {error:.3f} |")


if __name__ == "__main__":
    main()
