"""A loop with two coupled values each way (ssp/coupling/algebraic_loop2.ssp, loop2_exact.py), where the coupling
updates of the iterative algorithm differ; on the shipped one-value loop Aitken and IQN-ILS are both the secant
method and take the same iterations. Expectations from the loop matrix (eigenvalues 0.739 and -0.589): IQN-ILS
solves a linear loop of n values exactly once it has n residual differences (iteration n + 2, the first two being
the plain and the relaxed step), Aitken's single factor cannot zero two eigenvalues of opposite sign at once,
and the fixed point contracts by 0.739 per iteration."""
import math
from pathlib import Path

import numpy as np
import pytest

import master
from coupling_refs import coupling_reference

REPO = Path(__file__).resolve().parents[3]
COUPLING = REPO / "ssp" / "coupling"


L2 = coupling_reference("loop2_exact")
SIGNALS = ["P.y1", "P.y2", "Q.y1", "Q.y2"]


def _run(update, ssp="algebraic_loop2", signals=SIGNALS):
    return master.run(COUPLING / f"{ssp}.ssp", algorithm="iterative", coupling_update=update, coupling_tol=1e-10,
                      coupling_max_iter=200, record=signals)


def test_the_closed_form_satisfies_both_blocks():
    t = np.linspace(0.0, 10.0, 11)
    y = L2.loop2(t)
    yp, yq = np.stack([y["P.y1"], y["P.y2"]]), np.stack([y["Q.y1"], y["Q.y2"]])
    P, Q = L2.LOOP2["P"], L2.LOOP2["Q"]
    gp = np.stack([P["b1"] + P["c"] * np.sin(P["w"] * t), np.full_like(t, P["b2"])])
    gq = np.stack([Q["b1"] + Q["c"] * np.sin(Q["w"] * t), np.full_like(t, Q["b2"])])
    np.testing.assert_allclose(yp, L2.matrix(P) @ yq + gp, atol=1e-12)
    np.testing.assert_allclose(yq, L2.matrix(Q) @ yp + gq, atol=1e-12)


def test_every_update_reaches_the_fixed_point_and_iqn_ils_needs_the_fewest_iterations():
    iterations = {}
    for update in ("fixed-point", "aitken", "iqn-ils"):
        r = _run(update)
        info = r.metadata["algorithm_info"]
        assert info["not_converged_steps"] == 0 and len(info["loops_broken_at"]) == 2
        t = r.frame["time"].to_numpy()
        want = L2.loop2(t)
        for name in SIGNALS:
            np.testing.assert_allclose(r.frame[name].to_numpy(), want[name], atol=1e-8)
        iterations[update] = info["iterations_max"]
    assert iterations["iqn-ils"] == 2 + 2                       # n + 2 for n = 2 loop values
    assert iterations["iqn-ils"] < iterations["aitken"] < iterations["fixed-point"]
    # the fixed point contracts by the loop's spectral radius (0.739) per iteration: from the change of the
    # values over a step (~1e-2) to 1e-10 takes ln(1e-8) / ln(0.739) ~ 61 iterations
    rho = max(abs(np.linalg.eigvals(L2.matrix(L2.LOOP2["Q"]) @ L2.matrix(L2.LOOP2["P"]))))
    assert iterations["fixed-point"] == pytest.approx(math.log(1e-8) / math.log(rho), rel=0.2)


def test_on_the_one_value_loop_aitken_and_iqn_ils_are_the_same_secant_method():
    runs = {u: _run(u, "algebraic_loop", ["L1.y", "L2.y"]) for u in ("aitken", "iqn-ils")}
    assert (runs["aitken"].metadata["algorithm_info"]["iterations_total"]
            == runs["iqn-ils"].metadata["algorithm_info"]["iterations_total"])
