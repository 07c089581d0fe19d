"""Closed-form references of the coupling benchmarks (``cosim-master study ... --reference
analytic:ssp/coupling/oscillator_exact.py:fd``): functions of time returning the signals by their
'component.variable' names. The parameter sets here are the ones ssp/coupling/build.py writes into the SSPs.

Two-mass oscillator  m1 x1'' = -k1 x1 - kc (x1 - x2),  m2 x2'' = -k2 x2 - kc (x2 - x1):
with M = diag(m1, m2) and K = [[k1 + kc, -kc], [-kc, k2 + kc]], q = M^(1/2) x obeys q'' = -A q with the symmetric
A = M^(-1/2) K M^(-1/2) = Q diag(w^2) Q^T, so each mode is a harmonic oscillator (modal decomposition).

Algebraic loop of two Affine blocks y = a u + g(t), g = b + c sin(w t), wired L1.y -> L2.u, L2.y -> L1.u:
y1 = a1 y2 + g1, y2 = a2 y1 + g2, so y1 = (g1 + a1 g2) / (1 - a1 a2) and y2 = a2 y1 + g2.
"""
import numpy as np

OSCILLATOR = dict(m1=1.0, k1=1.0, m2=1.0, k2=1.0, kc=1.0, x10=1.0, v10=0.0, x20=0.0, v20=0.0)
STIFF = dict(OSCILLATOR, kc=1000.0)          # the coupling spring 1000 times stiffer
LOOP = dict(L1=dict(a=0.5, b=1.0, c=0.5, w=1.0), L2=dict(a=-0.8, b=2.0, c=0.0, w=1.0))


def two_mass(t, m1, k1, m2, k2, kc, x10, v10, x20, v20):
    """(x1, v1, x2, v2) at the times t (seconds since the initial state)."""
    t = np.asarray(t, dtype=float)
    m = np.array([m1, m2])
    K = np.array([[k1 + kc, -kc], [-kc, k2 + kc]])
    s = 1.0 / np.sqrt(m)
    w2, Q = np.linalg.eigh(s[:, None] * K * s[None, :])
    w = np.sqrt(np.clip(w2, 0.0, None))
    eta0 = Q.T @ (np.sqrt(m) * np.array([x10, x20]))
    deta0 = Q.T @ (np.sqrt(m) * np.array([v10, v20]))
    wt = np.multiply.outer(t, w)
    safe = np.where(w > 0, w, 1.0)
    eta = eta0 * np.cos(wt) + np.where(w > 0, deta0 / safe * np.sin(wt), deta0 * t[..., None])
    deta = -eta0 * w * np.sin(wt) + deta0 * np.cos(wt)
    x = (eta @ Q.T) * s
    v = (deta @ Q.T) * s
    return x[..., 0], v[..., 0], x[..., 1], v[..., 1]


def _masses(t, p):
    x1, v1, x2, v2 = two_mass(t, **p)
    return {"A.x": x1, "A.v": v1, "B.x": x2, "B.v": v2}


def fd(t):
    """oscillator_fd.ssp (force-displacement coupling) and oscillator_dd.ssp: the masses' positions and
    velocities."""
    return _masses(t, OSCILLATOR)


dd = fd


def stiff(t):
    """oscillator_stiff.ssp: the coupling spring 1000 times stiffer."""
    return _masses(t, STIFF)


def loop(t):
    """algebraic_loop.ssp: the fixed point of the loop at every time."""
    t = np.asarray(t, dtype=float)
    p1, p2 = LOOP["L1"], LOOP["L2"]
    g1 = p1["b"] + p1["c"] * np.sin(p1["w"] * t)
    g2 = p2["b"] + p2["c"] * np.sin(p2["w"] * t)
    y1 = (g1 + p1["a"] * g2) / (1.0 - p1["a"] * p2["a"])
    return {"L1.y": y1, "L2.y": p2["a"] * y1 + g2}
