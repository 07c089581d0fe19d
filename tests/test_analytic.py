"""Check analytic.py: the monolithic solution, convergence, and that the
closed-form co-simulation recurrences are exactly what a literal
implementation of the documented semantics produces with the real FMUs."""

from __future__ import annotations

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

import analytic as an


# ---------------------------------------------------------------------------
# monolithic solution


def test_two_mass_exact_symmetric_modes():
    t = np.linspace(0.0, 20.0, 201)
    x1, v1, x2, v2 = an.two_mass_exact(t)
    w1, w2 = 1.0, np.sqrt(3.0)  # in-phase and anti-phase modes
    np.testing.assert_allclose(x1, 0.5 * (np.cos(w1 * t) + np.cos(w2 * t)), atol=1e-14)
    np.testing.assert_allclose(x2, 0.5 * (np.cos(w1 * t) - np.cos(w2 * t)), atol=1e-14)
    np.testing.assert_allclose(v1, -0.5 * (w1 * np.sin(w1 * t) + w2 * np.sin(w2 * t)), atol=1e-14)


def test_two_mass_exact_general_energy_and_ode():
    p = dict(m1=2.0, k1=3.0, m2=0.5, k2=0.7, kc=1.3, x10=0.3, v10=-1.0, x20=0.2, v20=0.5)
    t = np.linspace(0.0, 5.0, 50001)
    x1, v1, x2, v2 = an.two_mass_exact(t, **p)
    E = 0.5 * (p["m1"] * v1**2 + p["m2"] * v2**2 + p["k1"] * x1**2 + p["k2"] * x2**2 + p["kc"] * (x1 - x2) ** 2)
    assert np.ptp(E) < 1e-12
    assert (x1[0], v1[0], x2[0], v2[0]) == pytest.approx((0.3, -1.0, 0.2, 0.5))
    dt = t[1] - t[0]
    a1 = np.gradient(v1, dt)
    np.testing.assert_allclose(p["m1"] * a1[1:-1], (-p["k1"] * x1 - p["kc"] * (x1 - x2))[1:-1], atol=1e-6)


def test_two_mass_exact_free_mode():
    # no walls: rigid-body mode with omega = 0
    x1, v1, x2, v2 = an.two_mass_exact(np.array([0.0, 2.0]), k1=0.0, k2=0.0, kc=1.0, x10=0.0, v10=1.0)
    assert (x1[1] + x2[1]) / 2 == pytest.approx(1.0)  # centre of mass moves with v = 0.5


@pytest.mark.parametrize("method", an.METHODS)
def test_cosim_first_order_convergence(method):
    errors = []
    for h in (0.04, 0.02, 0.01):
        n = int(round(4.0 / h))
        r = an.two_mass_cosim(n, h, method)
        e1, _, e2, _ = an.two_mass_exact(r["time"])
        errors.append(max(np.abs(r["x1"] - e1).max(), np.abs(r["x2"] - e2).max()))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.8) & (ratios < 2.2)), (errors, ratios)


@pytest.mark.parametrize("method", an.METHODS)
def test_chain_first_order_convergence(method):
    errors = []
    for h in (0.02, 0.01, 0.005):
        r = an.chain_recurrence(int(round(2.0 / h)), h, method, a1=-0.5, a2=-0.2, k=-1.0)
        e1, e2 = an.chain_exact(r["time"], a1=-0.5, a2=-0.2, k=-1.0)
        errors.append(max(np.abs(r["I1.y"] - e1).max(), np.abs(r["I2.y"] - e2).max()))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.8) & (ratios < 2.2)), (errors, ratios)


def test_chain_closed_forms_small_cases():
    h, k = 0.1, 2.0
    j = an.chain_recurrence(2, h, "jacobi", k=k)
    # x1_1 = 1, x2_1 = h k; x1_2 = 1 + h^2 k, x2_2 = 2 h k
    np.testing.assert_allclose(j["I1.y"], [1, 1, 1 + h * h * k])
    np.testing.assert_allclose(j["I2.y"], [0, h * k, 2 * h * k])
    g = an.chain_recurrence(1, h, "gauss_seidel", k=k)
    np.testing.assert_allclose(g["I2.y"], [0, h * k * 1.0])
    d = an.chain_recurrence(3, h, "jacobi_delayed", k=k)
    np.testing.assert_allclose(d["Gain.y"], [k, k, k, k * (1 + h * h * k)])
    np.testing.assert_allclose(d["I2.y"], [0, h * k, 2 * h * k, 3 * h * k])


# ---------------------------------------------------------------------------
# a literal reference master with the three documented semantics


class _Comp:
    def __init__(self, path, name):
        md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                               modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.slave.instantiate()
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()

    def get(self, var):
        return self.slave.getReal([self.vr[var]])[0]

    def set(self, var, value):
        self.slave.setReal([self.vr[var]], [value])


def reference_master(fmus, connections, params, method, n_steps, h, record, order=None):
    comps = {name: _Comp(path, name) for name, path in fmus.items()}
    for (c, v), val in params.items():
        comps[c].set(v, val)

    def propagate():  # set every input from its source; repeat to resolve feedthrough chains
        for _ in range(len(comps)):
            for sc, sv, dc, dv in connections:
                comps[dc].set(dv, comps[sc].get(sv))

    propagate()
    for c in comps.values():
        c.slave.exitInitializationMode()
    propagate()
    cache = {(sc, sv): comps[sc].get(sv) for sc, sv, _, _ in connections}
    rows = []

    def snapshot():
        if method == "jacobi_delayed":
            return [cache.get(key, comps[key[0]].get(key[1])) for key in record]
        return [comps[c].get(v) for c, v in record]

    rows.append(snapshot())
    t = 0.0
    for _ in range(n_steps):
        if method == "jacobi":
            propagate()
            for c in comps.values():
                c.slave.doStep(t, h)
        elif method == "gauss_seidel":
            for name in order:
                for sc, sv, dc, dv in connections:
                    if dc == name:
                        comps[dc].set(dv, comps[sc].get(sv))
                comps[name].slave.doStep(t, h)
        else:  # jacobi_delayed: deliver cached outputs, step, re-read outputs
            for sc, sv, dc, dv in connections:
                comps[dc].set(dv, cache[(sc, sv)])
            for c in comps.values():
                c.slave.doStep(t, h)
            cache = {(sc, sv): comps[sc].get(sv) for sc, sv, _, _ in connections}
            cache.update({key: comps[key[0]].get(key[1]) for key in record})
        t += h
        if method == "jacobi":
            propagate()
        rows.append(snapshot())
    for c in comps.values():
        c.slave.terminate()
        c.slave.freeInstance()
    return np.array(rows)


CASES = [("jacobi", None), ("gauss_seidel", ("A", "B")), ("gauss_seidel", ("B", "A")), ("jacobi_delayed", None)]


@pytest.mark.parametrize("family", ["c2", "py"])
@pytest.mark.parametrize("method,order", CASES)
def test_two_mass_recurrence_matches_fmus(test_fmus, family, method, order):
    p = dict(m1=1.2, k1=0.8, m2=0.7, k2=1.1, kc=1.9, x10=0.9, v10=0.1, x20=-0.2, v20=0.3)
    params = {("A", "m"): p["m1"], ("A", "k"): p["k1"], ("A", "x0"): p["x10"], ("A", "v0"): p["v10"],
              ("B", "m"): p["m2"], ("B", "k"): p["k2"], ("B", "kc"): p["kc"], ("B", "x0"): p["x20"],
              ("B", "v0"): p["v20"]}
    h, n = 0.05, 40
    rows = reference_master({"A": test_fmus[f"{family}:MassA"], "B": test_fmus[f"{family}:MassB"]},
                            [("A", "x", "B", "x_in"), ("B", "F", "A", "F")], params, method, n, h,
                            [("A", "x"), ("A", "v"), ("B", "x"), ("B", "v")], order=order)
    r = an.two_mass_cosim(n, h, method, order=order or ("A", "B"), **p)
    for i, key in enumerate(("x1", "v1", "x2", "v2")):
        np.testing.assert_allclose(rows[:, i], r[key], atol=1e-12, err_msg=key)


@pytest.mark.parametrize("family", ["c2", "py"])
@pytest.mark.parametrize("method", an.METHODS)
def test_chain_recurrence_matches_fmus(test_fmus, family, method):
    a1, a2, k, x10, x20 = -0.5, 0.3, -1.7, 1.2, 0.4
    params = {("I1", "a"): a1, ("I1", "x0"): x10, ("I2", "a"): a2, ("I2", "x0"): x20, ("G", "k"): k}
    integ = test_fmus[f"{family}:Integrator"]
    h, n = 0.1, 30
    rows = reference_master({"I1": integ, "G": test_fmus[f"{family}:Gain"], "I2": integ},
                            [("I1", "y", "G", "u"), ("G", "y", "I2", "u"), ("I2", "y", "I1", "u")],
                            params, method, n, h, [("I1", "y"), ("G", "y"), ("I2", "y")],
                            order=("I1", "G", "I2"))
    r = an.chain_recurrence(n, h, method, a1=a1, a2=a2, k=k, x10=x10, x20=x20)
    np.testing.assert_allclose(rows[:, 0], r["I1.y"], atol=1e-12)
    np.testing.assert_allclose(rows[:, 1], r["Gain.y"], atol=1e-12)
    np.testing.assert_allclose(rows[:, 2], r["I2.y"], atol=1e-12)
