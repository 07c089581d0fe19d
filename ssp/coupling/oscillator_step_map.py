"""Closed-form step maps of the two-mass oscillator benchmarks (oscillator_fd/_dd/_stiff.ssp) under the master's
fixed-step schemes: the matrix S with z_{n+1} = S z_n, and its spectral radius, derived by hand from the
subsystems' exact transition matrices (docs/coupling.md, "Stability of the coupled step"). Independent of the
master's code: the test of master/stability/ compares the spectral radius it identifies from the FMUs with these.

Each half is m x'' = -K x + f with f held over the step, integrated exactly by its FMU, so over a step h
(matrix exponential of the augmented system [[M, g], [0, 0]] h):

    (x, v)_{n+1} = Phi (x, v)_n + Gamma f,     M = [[0, 1], [-K/m, 0]],  g = (0, 1/m)

MassA (fd): K = k1, f = F (its input).  MassB: K = k2 + kc, f = kc x_in, and its output F = kc (x2 - x_in) is
read with the input it holds.

The state of the coupled map is z = (x1, v1, x2, v2, y_n, y_{n-1}, ..., y_{n-D}), y = (x1, c) the coupled outputs
as the master keeps them (c = F for fd, x2 for dd): a sample coordinate that equals a function of the others only
adds an eigenvalue 0, which leaves the spectral radius alone.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import expm

# by hand: the mean over [t_n, t_n + h] of the polynomial through y_n, y_{n-1}, ... (extrapolation K), and through
# y_{n+1}, y_n, y_{n-1} (Gauss-Seidel interpolation M)
EXTRAPOLATION = {0: (1.0,), 1: (1.5, -0.5), 2: (23 / 12, -16 / 12, 5 / 12)}
INTERPOLATION = {1: (0.5, 0.5), 2: (5 / 12, 8 / 12, -1 / 12)}


def transition(m: float, K: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(Phi, Gamma) of m x'' = -K x + f over h with f constant."""
    aug = np.zeros((3, 3))
    aug[0, 1] = 1.0
    aug[1, 0] = -K / m
    aug[1, 2] = 1.0 / m
    e = expm(aug * h)
    return e[:2, :2], e[:2, 2]


def step_map(coupling: str, scheme: str, h: float, p: dict, extrapolation: int = 0,
             interpolation: int = 0) -> np.ndarray:
    """S for ``coupling`` "fd" (A = MassA, B = MassB) or "dd" (both MassB) and ``scheme`` "jacobi",
    "gauss-seidel" (A steps first) or "iterative" (converged: every input at its end-of-step value), with the
    parameters ``p`` of oscillator_exact (m1, k1, m2, k2, kc)."""
    if coupling == "fd":
        phi_a, gam_a = transition(p["m1"], p["k1"], h)
        gain_a = 1.0                                    # A's input is the force itself
    else:
        phi_a, gam_a = transition(p["m1"], p["k1"] + p["kc"], h)
        gain_a = p["kc"]                                # A holds the coupling spring: f = kc x_in
    phi_b, gam_b = transition(p["m2"], p["k2"] + p["kc"], h)
    kc = p["kc"]
    depth = max(extrapolation, interpolation - 1, 0) + 1        # samples y_n ... y_{n-depth+1} kept
    n = 4 + 2 * depth
    # linear functionals over z: rows
    eye = np.eye(n)
    a, b = eye[0:2], eye[2:4]
    x1 = [eye[4 + 2 * j] for j in range(depth)]                 # x1_{n-j}
    c = [eye[5 + 2 * j] for j in range(depth)]                  # F_{n-j} or x2_{n-j}
    refresh = coupling == "fd" and bool(extrapolation or interpolation)    # feedthrough samples re-read

    def held_mean(samples, k):
        return sum(w * samples[j] for j, w in enumerate(EXTRAPOLATION[k]))

    if scheme == "iterative":
        # unknowns u = (uA, x1'): uA = c', uB = x1'; a' = Phi_A a + Gamma_A gain_a uA, b' = Phi_B b + Gamma_B uB
        # x1' = e1 a' ;  fd: c' = kc (x2' - x1');  dd: c' = x2'
        # write x1' = X0 + X1 uA,  x2' = Y0 + Y1 x1'   (X0, Y0 rows over z)
        X0, X1 = phi_a[0] @ a, gain_a * gam_a[0]
        Y0, Y1 = phi_b[0] @ b, kc * gam_b[0]
        # c' = s (x2' - r x1') with (s, r) = (kc, 1) for fd, (1, 0) for dd;  uA = c'
        s, r = (kc, 1.0) if coupling == "fd" else (1.0, 0.0)
        # uA = s (Y0 + (Y1 - r) (X0 + X1 uA))  =>  uA (1 - s (Y1 - r) X1) = s (Y0 + (Y1 - r) X0)
        uA = s * (Y0 + (Y1 - r) * X0) / (1.0 - s * (Y1 - r) * X1)
        uB = X0 + X1 * uA
        a_new = phi_a @ a + np.outer(gain_a * gam_a, uA)
        b_new = phi_b @ b + np.outer(kc * gam_b, uB)
        c_new = uA
    else:
        uA = held_mean(c, extrapolation)
        a_new = phi_a @ a + np.outer(gain_a * gam_a, uA)
        x1_new = a_new[0]
        if scheme == "jacobi":
            uB = held_mean(x1, extrapolation)
        elif interpolation:
            w = INTERPOLATION[interpolation]
            uB = w[0] * x1_new + sum(wj * x1[j] for j, wj in enumerate(w[1:]))
        else:
            uB = x1_new
        b_new = phi_b @ b + np.outer(kc * gam_b, uB)
        if coupling == "dd":
            c_new = b_new[0]
        else:
            c_new = kc * (b_new[0] - (x1_new if refresh else uB))
    S = np.zeros((n, n))
    S[0:2], S[2:4] = a_new, b_new
    S[4], S[5] = a_new[0], c_new
    for j in range(1, depth):              # the samples move back by one
        S[4 + 2 * j], S[5 + 2 * j] = x1[j - 1], c[j - 1]
    return S


def spectral_radius(coupling: str, scheme: str, h: float, p: dict, extrapolation: int = 0,
                    interpolation: int = 0) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(step_map(coupling, scheme, h, p, extrapolation, interpolation)))))
