"""Closed form of algebraic_loop2.ssp (``--reference analytic:ssp/coupling/loop2_exact.py:loop2``): two Affine2
blocks y = A u + g(t), g = (b1 + c sin(w t), b2), wired P.y -> Q.u and Q.y -> P.u (two values each way). The
parameters here are the ones fmu_sources/coupling/build.py writes into the SSP.

y_P = A_P y_Q + g_P and y_Q = A_Q y_P + g_Q, so y_P = (I - A_P A_Q)^-1 (g_P + A_P g_Q) and y_Q = A_Q y_P + g_Q.
The loop map that an iteration on Q's outputs repeats is u -> A_Q (A_P u + g_P) + g_Q, with the matrix
A_Q A_P (or A_P A_Q when Q steps first, the same eigenvalues): here 0.739 and -0.589 (fixed point converges
slowly, one relaxation factor cannot serve both).
"""
import numpy as np

# A_Q swaps the two values; A_Q A_P = [[0.45, 0.6], [0.5, -0.3]] (trace 0.15, determinant -0.435)
LOOP2 = dict(P=dict(a11=0.5, a12=-0.3, a21=0.45, a22=0.6, b1=1.0, b2=0.5, c=0.5, w=1.0),
             Q=dict(a11=0.0, a12=1.0, a21=1.0, a22=0.0, b1=-0.2, b2=0.3, c=0.0, w=1.0))


def matrix(p):
    return np.array([[p["a11"], p["a12"]], [p["a21"], p["a22"]]])


def _g(p, t):
    return np.stack([p["b1"] + p["c"] * np.sin(p["w"] * t), np.full_like(t, p["b2"])])


def loop2(t):
    t = np.atleast_1d(np.asarray(t, dtype=float))
    P, Q = LOOP2["P"], LOOP2["Q"]
    ap, aq = matrix(P), matrix(Q)
    yp = np.linalg.solve(np.eye(2) - ap @ aq, _g(P, t) + ap @ _g(Q, t))
    yq = aq @ yp + _g(Q, t)
    return {"P.y1": yp[0], "P.y2": yp[1], "Q.y1": yq[0], "Q.y2": yq[1]}
