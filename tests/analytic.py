"""Reference solutions for the master's tests.

Everything here is plain numpy; the functions are exact (up to round-off) for
the test FMUs built by ``tests/fmu_factory.py``.

1. Monolithic two-mass oscillator (``two_mass_exact``)
---------------------------------------------------------
    m1 x1'' = -k1 x1 - kc (x1 - x2)
    m2 x2'' = -k2 x2 - kc (x2 - x1)
solved by modal decomposition: with M = diag(m1, m2) and
K = [[k1+kc, -kc], [-kc, k2+kc]], q = M^(1/2) x obeys q'' = -A q with the
symmetric A = M^(-1/2) K M^(-1/2) = Q diag(w^2) Q^T (numpy.linalg.eigh), so
every mode is a harmonic oscillator.

2. Co-simulation of the split FMUs
----------------------------------
FMU "MassA" integrates m1 x1'' = -k1 x1 + F exactly for F held constant over
the step; FMU "MassB" integrates m2 x2'' = -(k2+kc) x2 + kc x_in exactly for
x_in held constant and outputs F = kc (x2 - x_in) (direct feedthrough).
FMU "Integrator" does exactly one explicit Euler step x += h (a x + u),
y = x (no feedthrough); "Gain" outputs y = k u (direct feedthrough).
Because every FMU step is an exact linear map, a fixed-step co-simulation is
a linear recurrence z_{n+1} = T z_n and we evaluate it in closed form with
matrix powers, z_n = T^n z_0 (``numpy.linalg.matrix_power``).

Communication points are t_n = t0 + n h, n = 0..N.  Row n of every result
holds the values at t_n, as read by the master after the exchange at t_n
(row 0: after initialization, i.e. the start values of the states, with
feedthrough outputs evaluated from the initial inputs).

The exact semantics assumed ("method"):

``"jacobi"`` -- Jacobi with feedthrough resolved at the exchange.
    Exchange at t_n happens after *all* components finished step n-1.  The
    master reads the outputs that have no direct feedthrough (states), sets
    them on the connected inputs, and evaluates direct-feedthrough outputs
    (Gain.y, MassB.F) *after* their own inputs were set at this same exchange
    (in topological order of the feedthrough graph; algebraic loops are not
    allowed).  Then every component steps [t_n, t_n+h] with these inputs.
        chain:  u1 = x2_n,  Gain.u = x1_n,  Gain.y = k x1_n,  u2 = k x1_n
        masses: B.x_in = x1_n,  A.F = kc (x2_n - x1_n)

``"gauss_seidel"`` -- sequential (Gauss-Seidel) in the given ``order``.
    Components step one after the other; right before a component steps, its
    inputs are set from the *latest* available outputs, where a feedthrough
    output (Gain.y, MassB.F) is evaluated with the inputs its component has
    at that moment (a component that has already stepped in this sweep keeps
    the inputs it stepped with).
        chain, order I1, Gain, I2:
            I1 steps with u1 = x2_n                        -> x1_{n+1}
            Gain.u = x1_{n+1}, Gain.y = k x1_{n+1}
            I2 steps with u2 = k x1_{n+1}                  -> x2_{n+1}
        masses, order ("A", "B"):
            B.x_in = x1_n, A steps with F = kc (x2_n - x1_n)
            B.x_in = x1_{n+1}, B steps
        masses, order ("B", "A"):
            B steps with x_in = x1_n                       -> x2_{n+1}
            A steps with F = kc (x2_{n+1} - x1_n)  (B still holds x_in = x1_n)

``"jacobi_delayed"`` -- what libcosim's fixed_step_algorithm does (see
    ``tests/peers/libcosim_runner.py``): outputs are read once, right after
    each component's doStep, *before* the new inputs are set; connected
    values are delivered to the inputs and applied before the next doStep.
    A direct-feedthrough output therefore reflects the input of the previous
    step: it adds one step of delay.  Initialization iterates until the
    initial values are consistent, so at t_0 feedthrough outputs are
    evaluated with the initial inputs.
        chain:  g_0 = k x1_0,  g_{n+1} = k x1_n  (g = Gain.y as observed),
                u1 = x2_n,  u2 = g_n
        masses: Fc_0 = kc (x2_0 - x1_0),  Fc_{n+1} = kc (x2_{n+1} - x1_n),
                A.F = Fc_n,  B.x_in = x1_n

The chain Integrator1 -> Gain -> Integrator2 -> Integrator1.u is wired as
    I1.y -> Gain.u,   Gain.y -> I2.u,   I2.y -> I1.u
and the linear maps are (z = [x1, x2] or [x1, x2, g]):
    jacobi:          [[1+h a1, h], [h k, 1+h a2]]
    gauss_seidel:    [[1+h a1, h], [h k (1+h a1), 1+h a2+h^2 k]]
    jacobi_delayed:  [[1+h a1, h, 0], [0, 1+h a2, h], [k, 0, 0]]
"""

from __future__ import annotations

import numpy as np

METHODS = ("jacobi", "gauss_seidel", "jacobi_delayed")


# ---------------------------------------------------------------------------
# monolithic two-mass oscillator


def two_mass_exact(
    t,
    m1: float = 1.0,
    k1: float = 1.0,
    m2: float = 1.0,
    k2: float = 1.0,
    kc: float = 1.0,
    x10: float = 1.0,
    v10: float = 0.0,
    x20: float = 0.0,
    v20: float = 0.0,
):
    """Exact solution of the coupled two-mass oscillator.

    Returns arrays ``x1, v1, x2, v2`` with the shape of ``t`` (time since the
    initial state).  Defaults match the FMU defaults (MassA.x0 = 1).
    """
    t = np.asarray(t, dtype=float)
    m = np.array([m1, m2], dtype=float)
    if np.any(m <= 0):
        raise ValueError("masses must be positive")
    K = np.array([[k1 + kc, -kc], [-kc, k2 + kc]], dtype=float)
    s = 1.0 / np.sqrt(m)
    A = s[:, None] * K * s[None, :]
    w2, Q = np.linalg.eigh(A)
    if np.any(w2 < -1e-12 * max(1.0, np.abs(w2).max())):
        raise ValueError("stiffness matrix must be positive semi-definite")
    w2 = np.clip(w2, 0.0, None)
    w = np.sqrt(w2)
    sq = np.sqrt(m)
    eta0 = Q.T @ (sq * np.array([x10, x20]))
    deta0 = Q.T @ (sq * np.array([v10, v20]))
    tt = t[..., None]  # broadcast over modes
    c = np.cos(w * tt)
    with np.errstate(divide="ignore", invalid="ignore"):
        sin_over_w = np.where(w > 0, np.sin(w * tt) / np.where(w > 0, w, 1.0), tt)
    eta = eta0 * c + deta0 * sin_over_w
    deta = -eta0 * w * np.sin(w * tt) + deta0 * c
    q = eta @ Q.T
    dq = deta @ Q.T
    x = q * s
    v = dq * s
    return x[..., 0], v[..., 0], x[..., 1], v[..., 1]


# ---------------------------------------------------------------------------
# exact one-step maps of the FMUs


def oscillator_step_map(m: float, K: float, h: float):
    """Exact step of m x'' = -K x + f with f constant.

    Returns ``(P, q)`` with ``[x, v]_{next} = P @ [x, v] + q * f``.
    """
    if m <= 0 or K < 0:
        raise ValueError("need m > 0 and K >= 0")
    if K == 0:
        P = np.array([[1.0, h], [0.0, 1.0]])
        q = np.array([h * h / (2 * m), h / m])
        return P, q
    w = np.sqrt(K / m)
    c, s = np.cos(w * h), np.sin(w * h)
    P = np.array([[c, s / w], [-w * s, c]])
    q = np.array([(1 - c) / K, w * s / K])
    return P, q


def _check_method(method: str):
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")


def _powers(T: np.ndarray, z0: np.ndarray, n_steps: int) -> np.ndarray:
    """Rows z_n = T^n z0 for n = 0..n_steps (matrix powers)."""
    return np.array([np.linalg.matrix_power(T, n) @ z0 for n in range(n_steps + 1)])


# ---------------------------------------------------------------------------
# two-mass co-simulation (MassA + MassB)


def two_mass_cosim_matrix(
    h: float,
    method: str = "jacobi",
    order: tuple[str, str] = ("A", "B"),
    m1: float = 1.0,
    k1: float = 1.0,
    m2: float = 1.0,
    k2: float = 1.0,
    kc: float = 1.0,
) -> np.ndarray:
    """One-step map T of the MassA/MassB co-simulation.

    State z = [x1, v1, x2, v2] (and Fc, the cached force, for
    ``"jacobi_delayed"``).  ``order`` only matters for ``"gauss_seidel"``.
    """
    _check_method(method)
    PA, qA = oscillator_step_map(m1, k1, h)
    PB, qB = oscillator_step_map(m2, k2 + kc, h)
    e = np.eye(5 if method == "jacobi_delayed" else 4)
    X1, V1, X2, V2 = e[0], e[1], e[2], e[3]

    def step_A(F_row):  # rows of [x1, v1]_{n+1} as functions of z_n
        return PA[:, :1] * X1 + PA[:, 1:] * V1 + qA[:, None] * F_row

    def step_B(xin_row):  # rows of [x2, v2]_{n+1}; force kc * x_in
        return PB[:, :1] * X2 + PB[:, 1:] * V2 + qB[:, None] * (kc * xin_row)

    if method == "jacobi":
        A_rows = step_A(kc * (X2 - X1))
        B_rows = step_B(X1)
        return np.vstack([A_rows, B_rows])
    if method == "gauss_seidel":
        if tuple(order) == ("A", "B"):
            A_rows = step_A(kc * (X2 - X1))
            B_rows = step_B(A_rows[0])
        elif tuple(order) == ("B", "A"):
            B_rows = step_B(X1)
            A_rows = step_A(kc * (B_rows[0] - X1))
        else:
            raise ValueError("order must be ('A', 'B') or ('B', 'A')")
        return np.vstack([A_rows, B_rows])
    # jacobi_delayed
    FC = e[4]
    A_rows = step_A(FC)
    B_rows = step_B(X1)
    F_row = kc * (B_rows[0] - X1)
    return np.vstack([A_rows, B_rows, F_row[None, :]])


def two_mass_cosim(
    n_steps: int,
    h: float,
    method: str = "jacobi",
    order: tuple[str, str] = ("A", "B"),
    m1: float = 1.0,
    k1: float = 1.0,
    m2: float = 1.0,
    k2: float = 1.0,
    kc: float = 1.0,
    x10: float = 1.0,
    v10: float = 0.0,
    x20: float = 0.0,
    v20: float = 0.0,
) -> dict[str, np.ndarray]:
    """Exact result of co-simulating MassA + MassB with a fixed step h.

    Returns a dict with ``time`` (n*h, n = 0..n_steps) and ``x1, v1, x2, v2``
    (and ``F``, the force MassB.F as observed, for ``"jacobi_delayed"``).
    """
    T = two_mass_cosim_matrix(h, method, order, m1, k1, m2, k2, kc)
    z0 = [x10, v10, x20, v20]
    if method == "jacobi_delayed":
        z0.append(kc * (x20 - x10))
    Z = _powers(T, np.array(z0, dtype=float), n_steps)
    out = {"time": h * np.arange(n_steps + 1), "x1": Z[:, 0], "v1": Z[:, 1], "x2": Z[:, 2], "v2": Z[:, 3]}
    if method == "jacobi_delayed":
        out["F"] = Z[:, 4]
    return out


# ---------------------------------------------------------------------------
# Integrator1 -> Gain -> Integrator2 -> Integrator1 chain


def chain_matrix(h: float, method: str = "jacobi", a1: float = 0.0, a2: float = 0.0, k: float = 1.0) -> np.ndarray:
    """One-step map of the chain; state [x1, x2] (jacobi, gauss_seidel) or
    [x1, x2, g] (jacobi_delayed, g = Gain.y as cached by libcosim)."""
    _check_method(method)
    if method == "jacobi":
        return np.array([[1 + h * a1, h], [h * k, 1 + h * a2]])
    if method == "gauss_seidel":
        return np.array([[1 + h * a1, h], [h * k * (1 + h * a1), 1 + h * a2 + h * h * k]])
    return np.array([[1 + h * a1, h, 0.0], [0.0, 1 + h * a2, h], [k, 0.0, 0.0]])


def chain_recurrence(
    n_steps: int,
    h: float,
    method: str = "jacobi",
    a1: float = 0.0,
    a2: float = 0.0,
    k: float = 1.0,
    x10: float = 1.0,
    x20: float = 0.0,
) -> dict[str, np.ndarray]:
    """Closed-form co-simulation result of the chain

        Integrator1 (I1) -> Gain -> Integrator2 (I2) -> I1.u   (feedback)

    with the Integrator parameters ``a1``, ``x0 = x10`` (I1) and ``a2``,
    ``x0 = x20`` (I2) and ``Gain.k = k``.  Gauss-Seidel uses the order
    I1, Gain, I2.  Returns ``time`` and the outputs at every communication
    point: ``I1.y``, ``Gain.y``, ``I2.y`` (see the module docstring for the
    exact semantics of each method).
    """
    T = chain_matrix(h, method, a1, a2, k)
    if method == "jacobi_delayed":
        Z = _powers(T, np.array([x10, x20, k * x10]), n_steps)
        g = Z[:, 2]
    else:
        Z = _powers(T, np.array([x10, x20], dtype=float), n_steps)
        g = k * Z[:, 0]
    return {"time": h * np.arange(n_steps + 1), "I1.y": Z[:, 0], "Gain.y": g, "I2.y": Z[:, 1]}


def chain_exact(t, a1: float = 0.0, a2: float = 0.0, k: float = 1.0, x10: float = 1.0, x20: float = 0.0):
    """Continuous-time solution of x1' = a1 x1 + x2, x2' = a2 x2 + k x1.

    Returns ``x1, x2`` (uses an eigen-decomposition; the system matrix must be
    diagonalizable, which holds e.g. for k != 0 or a1 != a2).
    """
    t = np.asarray(t, dtype=float)
    A = np.array([[a1, 1.0], [k, a2]])
    lam, V = np.linalg.eig(A)
    c = np.linalg.solve(V, np.array([x10, x20], dtype=complex))
    z = (np.exp(lam * t[..., None]) * c) @ V.T
    return z[..., 0].real, z[..., 1].real


# ---------------------------------------------------------------------------
# variable steps and energy (adaptive and ECCO tests)


def two_mass_cosim_steps(
    steps,
    method: str = "jacobi_delayed",
    m1: float = 1.0,
    k1: float = 1.0,
    m2: float = 1.0,
    k2: float = 1.0,
    kc: float = 1.0,
    x10: float = 1.0,
    v10: float = 0.0,
    x20: float = 0.0,
    v20: float = 0.0,
) -> dict[str, np.ndarray]:
    """Exact result of co-simulating MassA + MassB over the uneven steps ``steps`` (h_0, h_1, ...): the
    product of the one-step maps, z_{k+1} = T(h_k) z_k.  Returns ``time`` (the step ends, starting with 0)
    and ``x1, v1, x2, v2`` (and ``F`` for ``"jacobi_delayed"``), one row per step end."""
    z = [x10, v10, x20, v20] + ([kc * (x20 - x10)] if method == "jacobi_delayed" else [])
    rows = [np.array(z, dtype=float)]
    for h in steps:
        rows.append(two_mass_cosim_matrix(float(h), method, ("A", "B"), m1, k1, m2, k2, kc) @ rows[-1])
    Z = np.array(rows)
    out = {"time": np.concatenate([[0.0], np.cumsum(steps)]), "x1": Z[:, 0], "v1": Z[:, 1], "x2": Z[:, 2],
           "v2": Z[:, 3]}
    if method == "jacobi_delayed":
        out["F"] = Z[:, 4]
    return out


def two_mass_energy(x1, v1, x2, v2, m1: float = 1.0, k1: float = 1.0, m2: float = 1.0, k2: float = 1.0,
                    kc: float = 1.0):
    """Kinetic plus spring energy of the two-mass oscillator (conserved by the exact solution)."""
    x1, v1, x2, v2 = (np.asarray(a, dtype=float) for a in (x1, v1, x2, v2))
    return 0.5 * (m1 * v1**2 + k1 * x1**2 + m2 * v2**2 + k2 * x2**2 + kc * (x2 - x1) ** 2)
