"""The algorithms against independently derived expectations: closed-form recurrences of a linear chain,
the analytic solution of a two-mass oscillator, multi-rate holding, exact step counting."""
import numpy as np
import pytest

import master
from master.ssp.writer import SspBuilder


def _exact_two_mass(t, m1=1.0, k1=1.0, m2=1.0, k2=1.0, kc=1.0, x10=1.0, x20=0.0):
    """Monolithic solution by modal decomposition of M x'' = -K x (both masses start at rest)."""
    K = np.array([[k1 + kc, -kc], [-kc, k2 + kc]])
    m_isqrt = np.diag(1.0 / np.sqrt([m1, m2]))
    w2, V = np.linalg.eigh(m_isqrt @ K @ m_isqrt)
    q0 = V.T @ (np.sqrt([m1, m2]) * np.array([x10, x20]))
    q = q0[:, None] * np.cos(np.sqrt(w2)[:, None] * t[None, :])
    return m_isqrt @ V @ q


def _oscillator(tmp_path, kind, h, stop=10.0):
    b = SspBuilder("osc", stop=stop, step=h)
    b.add_component("A", kind["MassA"], params={"x0": 1.0})
    b.add_component("B", kind["MassB"])
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    return b.write(tmp_path / f"osc_{h}.ssp")


@pytest.mark.parametrize("impl", ["c2", "py"])
def test_two_mass_oscillator_converges_first_order(tmp_path, test_fmus, impl):
    kind = {m: test_fmus[f"{impl}:{m}"] for m in ("MassA", "MassB")}
    steps = [0.04, 0.02, 0.01]
    err = {}
    for alg in ("jacobi", "gauss-seidel"):
        err[alg] = []
        for h in steps:
            df = master.run(_oscillator(tmp_path, kind, h), output=None, algorithm=alg, record=["A.x", "B.x"]).frame
            x = _exact_two_mass(df["time"].to_numpy())
            err[alg].append(max(np.max(np.abs(df["A.x"] - x[0])), np.max(np.abs(df["B.x"] - x[1]))))
        slopes = np.log2(np.array(err[alg][:-1]) / np.array(err[alg][1:]))
        # zero-order hold of the coupling makes the global error first order in h
        assert np.all((slopes > 0.85) & (slopes < 1.2)), (alg, err[alg], slopes)
    # Gauss-Seidel uses one fresher coupling value per step: closer at every step size
    for ej, eg in zip(err["jacobi"], err["gauss-seidel"]):
        assert eg < 0.75 * ej


def _chain(tmp_path, test_fmus, h, k, a1, a2, name="chain", fmi3=False):
    integ = test_fmus["c3:Integrator" if fmi3 else "c2:Integrator"]
    b = SspBuilder(name, stop=2.0, step=h)
    b.add_component("I1", integ, params={"a": a1, "x0": 1.0})
    b.add_component("G", test_fmus["c2:Gain"], params={"k": k})
    b.add_component("I2", integ, params={"a": a2, "x0": 0.5})
    b.connect("I1", "y", "G", "u")
    b.connect("G", "y", "I2", "u")
    b.connect("I2", "y", "I1", "u")
    return b.write(tmp_path / f"{name}.ssp")


@pytest.mark.parametrize("alg", ["jacobi", "gauss-seidel"])
def test_chain_matches_closed_form_recurrence(tmp_path, test_fmus, alg):
    h, k, a1, a2 = 0.05, -2.0, -0.3, 0.2
    df = master.run(_chain(tmp_path, test_fmus, h, k, a1, a2), output=None, algorithm=alg,
                    record=["I1.y", "G.y", "I2.y"]).frame
    # Each Integrator does x += h (a x + u) exactly; G.y = k u is read after G's input was set.
    # State s = (x1, g, x2). After initialization g0 = k x1_0.
    if alg == "jacobi":
        # every input is taken from the outputs read at the end of the previous step:
        # x1' = x1 + h(a1 x1 + x2), g' = k x1, x2' = x2 + h(a2 x2 + g)
        J = np.array([[1 + h * a1, 0, h], [k, 0, 0], [0, h, 1 + h * a2]])
    else:
        # order I1 -> G -> I2 (the feedback I2 -> I1 reads the previous step's value):
        # x1' = x1 + h(a1 x1 + x2), g' = k x1', x2' = x2 + h(a2 x2 + g')
        row1 = np.array([1 + h * a1, 0, h])
        row2 = k * row1
        row3 = np.array([0, 0, 1 + h * a2]) + h * row2
        J = np.vstack([row1, row2, row3])
    s = np.array([1.0, k * 1.0, 0.5])
    expected = [s]
    for _ in range(len(df) - 1):
        s = J @ s
        expected.append(s)
    expected = np.array(expected)
    got = df[["I1.y", "G.y", "I2.y"]].to_numpy()
    np.testing.assert_allclose(got, expected, rtol=1e-13, atol=1e-15)


def test_fmi3_and_fmi2_fmus_give_identical_results(tmp_path, test_fmus):
    args = dict(h=0.05, k=-2.0, a1=-0.3, a2=0.2)
    a = master.run(_chain(tmp_path, test_fmus, name="c2", **args), output=None, record=["I1.y", "I2.y"]).frame
    b = master.run(_chain(tmp_path, test_fmus, name="c3", fmi3=True, **args), output=None,
                   record=["I1.y", "I2.y"]).frame
    assert a.equals(b)


def test_python_and_native_fmus_agree(tmp_path, test_fmus):
    c = master.run(_oscillator(tmp_path, {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}, 0.05),
                   output=None, record=["A.x", "B.x"]).frame
    p = master.run(_oscillator(tmp_path, {m: test_fmus[f"py:{m}"] for m in ("MassA", "MassB")}, 0.05),
                   output=None, record=["A.x", "B.x"]).frame
    np.testing.assert_allclose(c.to_numpy(), p.to_numpy(), rtol=0, atol=1e-13)


def test_model_exchange_fmu_runs_with_an_integrator(tmp_path, test_fmus):
    b = SspBuilder("me", stop=10.0, step=0.1)
    b.add_component("osc", test_fmus["me2:Oscillator"])
    r = master.run(b.write(tmp_path / "me.ssp"), output=None, record=["osc.x", "osc.v"])
    assert r.metadata["fmus"]["osc"]["kind"] == "ModelExchange"
    df = r.frame
    # m x'' = -k x with m = k = 1, x(0) = 1, v(0) = 0
    np.testing.assert_allclose(df["osc.x"], np.cos(df["time"]), atol=1e-7)
    np.testing.assert_allclose(df["osc.v"], -np.sin(df["time"]), atol=1e-7)


def test_model_exchange_fmu_driven_by_an_input(tmp_path, test_fmus):
    # a constant force u = 1 moves the equilibrium to x = u / k = 1: x(t) = 1 exactly from x0 = 1
    b = SspBuilder("me", stop=5.0, step=0.1)
    b.add_component("src", test_fmus["c2:Integrator"], params={"x0": 1.0})
    b.add_component("osc", test_fmus["me2:Oscillator"])
    b.connect("src", "y", "osc", "u")
    df = master.run(b.write(tmp_path / "me2.ssp"), output=None, record=["osc.x"]).frame
    np.testing.assert_allclose(df["osc.x"], 1.0, atol=1e-8)


def test_integer_boolean_string_connections(tmp_path, test_fmus):
    b = SspBuilder("types", stop=0.3, step=0.1)
    b.add_component("t1", test_fmus["py:Types"])
    b.add_component("t2", test_fmus["py:Types"])
    for x in ("i", "b", "s", "r"):
        b.connect("t1", f"{x}_out", "t2", f"{x}_in")
    df = master.run(b.write(tmp_path / "types.ssp"), output=None, record=["t1.*", "t2.*"]).frame
    # t1 keeps its start inputs (0, false, "hello", 0.0); t2 gets t1's outputs
    assert list(df["t2.i_out"]) == [2, 2, 2, 2]
    assert list(df["t2.b_out"]) == [False] * 4 and list(df["t1.b_out"]) == [True] * 4
    assert list(df["t2.s_out"]) == ["hello!!"] * 4
    assert str(df["t2.i_out"].dtype) == "int32" and str(df["t2.b_out"].dtype) == "bool"
    assert list(df["t1.counter"]) == [0, 1, 2, 3]


def test_multi_rate_component_holds_its_inputs_and_outputs(tmp_path, test_fmus):
    h = 0.1
    b = SspBuilder("mr", stop=1.0, step=h, step_multiples={"slow": 5})
    b.add_component("ramp", test_fmus["c2:Integrator"], params={"x0": 0.0})
    b.add_component("one", test_fmus["c2:Integrator"], params={"x0": 1.0})
    b.add_component("slow", test_fmus["c2:Integrator"])
    b.add_component("probe", test_fmus["c2:Gain"])
    b.connect("one", "y", "ramp", "u")       # ramp.y = t
    b.connect("ramp", "y", "slow", "u")
    b.connect("slow", "y", "probe", "u")
    r = master.run(b.write(tmp_path / "mr.ssp"), output=None, algorithm="jacobi", record=["*.y"])
    df = r.frame
    t = df["time"].to_numpy()
    np.testing.assert_allclose(df["ramp.y"], t, atol=1e-14)
    # slow steps at t = 0 and 0.5 with step 0.5, its input held at ramp.y = 0 and 0.5 over each macro step:
    # x(0.5) = 0, x(1.0) = 0 + 0.5 * 0.5 = 0.25 (not the 0.5 * mean ramp a per-step input would give);
    # its new output becomes visible when its macro step ends
    assert list(df["slow.y"]) == pytest.approx([0.0] * 10 + [0.25])
    # probe (Gain, every step) sees the held output with the one-step Jacobi delay
    assert list(df["probe.y"]) == pytest.approx([0.0] * 10 + [0.0])
    assert r.metadata["step_multiples"] == {"slow": 5}


def test_recorded_only_outputs_are_read_when_sampled(tmp_path, test_fmus):
    # probe.y and slow.y feed nothing: the master reads them only when it records a row (slow, on a step
    # multiple, with its step). Rows taken every 0.3 s must equal the every-step rows at those times, and
    # the values must be the current ones: probe.y(t) = (t - h) - h (two Jacobi delays behind ramp.y = t)
    h = 0.1
    b = SspBuilder("rec", stop=1.8, step=h, step_multiples={"slow": 3})
    b.add_component("ramp", test_fmus["c2:Integrator"], params={"x0": 0.0})
    b.add_component("one", test_fmus["c2:Integrator"], params={"x0": 1.0})
    b.add_component("g", test_fmus["c2:Gain"])
    b.add_component("probe", test_fmus["c2:Integrator"], params={"a": 0.0})
    b.add_component("slow", test_fmus["c2:Integrator"])
    b.connect("one", "y", "ramp", "u")
    b.connect("ramp", "y", "g", "u")
    b.connect("g", "y", "probe", "u")
    b.connect("ramp", "y", "slow", "u")
    ssp = b.write(tmp_path / "rec.ssp")
    every = master.run(ssp, output=None, record=["probe.y", "slow.y"]).frame
    coarse = master.run(ssp, output=None, record=["probe.y", "slow.y"], record_interval=0.3).frame
    assert list(coarse["time"]) == pytest.approx([0.3 * k for k in range(7)])
    sub = every.iloc[::3].reset_index(drop=True)
    assert coarse.equals(sub)
    # probe integrates g.y = ramp.y delayed one step: x(t_n) = sum_{j<n} h * g.y(t_j), g.y(t_j) = t_{j-1}
    n = np.arange(len(every))
    expect = h * h * np.maximum(n - 1, 0) * np.maximum(n - 2, 0) / 2.0
    np.testing.assert_allclose(every["probe.y"], expect, atol=1e-12)


def test_exact_step_count_and_times_without_drift(tmp_path, test_fmus):
    b = SspBuilder("long", start=0.0, stop=1000.0, step=0.1)
    b.add_component("i", test_fmus["c2:Integrator"], params={"x0": 0.0})
    b.add_component("one", test_fmus["c2:Integrator"], params={"x0": 1.0})
    b.connect("one", "y", "i", "u")
    r = master.run(b.write(tmp_path / "long.ssp"), output=None, record=["i.y"])
    t = r.frame["time"].to_numpy()
    assert r.metadata["steps"] == 10000 and len(t) == 10001
    assert np.array_equal(t, np.arange(10001) * 0.1)       # t_n = start + n h, bit for bit
    assert t[-1] == 1000.0
    drift = np.cumsum(np.full(10000, 0.1))[-1]
    assert drift != 1000.0        # what accumulating the step would have given instead


def test_record_interval_and_determinism(tmp_path, test_fmus):
    ssp = _chain(tmp_path, test_fmus, 0.05, -2.0, -0.3, 0.2)
    a = master.run(ssp, output=tmp_path / "a", record_interval=0.5)
    b = master.run(ssp, output=tmp_path / "b", record_interval=0.5)
    assert list(a.frame["time"]) == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert a.frame.equals(b.frame)
    assert (tmp_path / "a" / "results.csv").read_bytes() == (tmp_path / "b" / "results.csv").read_bytes()


@pytest.mark.parametrize("alg", ["jacobi", "gauss-seidel"])
def test_pythonfmu_in_process_is_bit_identical_to_the_binary(tmp_path, test_fmus, alg):
    ssp = _oscillator(tmp_path, {m: test_fmus[f"py:{m}"] for m in ("MassA", "MassB")}, 0.05)
    a = master.run(ssp, output=None, algorithm=alg, record=["*"], inprocess=True).frame
    b = master.run(ssp, output=None, algorithm=alg, record=["*"], inprocess=False).frame
    assert a.equals(b)
    t = tmp_path / "types"
    bld = SspBuilder("types", stop=0.5, step=0.1)
    bld.add_component("t1", test_fmus["py:Types"])
    bld.add_component("t2", test_fmus["py:Types"])
    for x in ("i", "b", "s", "r"):
        bld.connect("t1", f"{x}_out", "t2", f"{x}_in")
    ssp = bld.write(tmp_path / "types.ssp")
    a = master.run(ssp, output=None, algorithm=alg, record=["*"], inprocess=True).frame
    b = master.run(ssp, output=None, algorithm=alg, record=["*"], inprocess=False).frame
    assert a.equals(b) and len(a) == 6


def test_algebraic_loop_that_does_not_settle_is_reported(tmp_path, test_fmus):
    # i_out = i_in + 1 on both sides of a loop has no fixed point
    bld = SspBuilder("loop", stop=0.5, step=0.1)
    bld.add_component("t1", test_fmus["py:Types"])
    bld.add_component("t2", test_fmus["py:Types"])
    bld.connect("t1", "i_out", "t2", "i_in")
    bld.connect("t2", "i_out", "t1", "i_in")
    with pytest.raises(master.CosimError) as e:
        master.run(bld.write(tmp_path / "loop.ssp"), output=None)
    assert "initialization did not settle after 100 iterations: algebraic loop" in str(e.value)
    assert "t1.i_out -> t2.i_in -> t2.i_out -> t1.i_in" in str(e.value)


def test_algebraic_loop_that_settles_is_run_and_reported(tmp_path, test_fmus):
    # y1 = 0.5 y2 and y2 = 0.5 y1 + (nothing else): the only fixed point is 0, reached geometrically
    bld = SspBuilder("loop", stop=0.2, step=0.1)
    bld.add_component("g1", test_fmus["c2:Gain"], params={"k": 0.5})
    bld.add_component("g2", test_fmus["c2:Gain"], params={"k": 0.5})
    bld.connect("g1", "y", "g2", "u")
    bld.connect("g2", "y", "g1", "u")
    r = master.run(bld.write(tmp_path / "loop.ssp"), output=None, params={"g1.u": "1.0"})
    assert r.metadata["algebraic_loops"] == [["g1.y", "g2.u", "g2.y", "g1.u"]]
    assert abs(r.frame["g1.y"].iloc[0]) < 1e-11


def test_inspect_shows_one_real_cycle_of_an_algebraic_loop_and_what_it_means(tmp_path, test_fmus):
    from master.inspect_scenario import format_inspect, inspect
    bld = SspBuilder("loop", stop=0.2, step=0.1)
    for name in ("g1", "g2", "sink"):
        bld.add_component(name, test_fmus["c2:Gain"], params={"k": 0.5})
    bld.connect("g1", "y", "g2", "u")
    bld.connect("g2", "y", "g1", "u")
    bld.connect("g2", "y", "sink", "u")      # downstream of the loop, not in it
    ssp = bld.write(tmp_path / "loop.ssp")
    info = inspect(ssp)
    # Gain declares y = k u (y depends on u): the cycle is two connections and two declared dependencies
    cycle = [(e["from"], e["to"], e["via"]) for e in info["algebraic_loop_cycles"][0]]
    assert cycle == [("g1.y", "g2.u", "connection"), ("g2.u", "g2.y", "declared"),
                     ("g2.y", "g1.u", "connection"), ("g1.u", "g1.y", "declared")]
    text = format_inspect(info)
    assert "algebraic loop between g1, g2 (4 ports), e.g. g1.y -> g2.u => g2.y -> g1.u => g1.y" in text
    assert "jacobi reads every input from the previous step" in text and "sink" not in text.split("algebraic")[1]
    assert "gauss-seidel steps it in order" in format_inspect(inspect(ssp, algorithm="gauss-seidel"))
    # the iterative and adaptive algorithms do not step in Gauss-Seidel order: each says what it does
    assert "iterative repeats each step" in format_inspect(inspect(ssp, algorithm="iterative"))
    assert "adaptive sweeps in Jacobi fashion" in format_inspect(inspect(ssp, algorithm="adaptive"))
