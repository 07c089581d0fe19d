"""The coupled step map of a fixed-step co-simulation, identified from its FMUs: z_{n+1} = S z_n near a
communication point, and its spectral radius (Kuebler and Schiehlen 2000: the scheme is stable for a step when the
radius is at most 1).

A master cannot set an FMU's internal state, but it can perturb what the FMUs are given. From a saved point after
a few warm-up steps (so that the extrapolation history is full), the algorithm's own step is run with one coupled
output sample perturbed (in the buffer and in the extrapolation history: a coordinate of the coupled state), and
then ``2 blocks`` steps more; the difference to the unperturbed run, per unit perturbation, is the free response
C S^k B of the coupled map, for every perturbed sample at once a block of Markov parameters. The Eigensystem
Realization Algorithm (Juang and Pappa 1985) turns their block Hankel matrices H0 = [Y_{i+j}] and H1 = [Y_{i+j+1}]
into a minimal realization: H0 = U s V^T cut at rank r, S_r = s^-1/2 U^T H1 V s^-1/2, whose eigenvalues are those
of the step map on the part of the coupled state the coupling excites and observes. Modes a component keeps to
itself (neither excited through its coupled inputs nor visible in its coupled outputs) are its own dynamics, which
no coupling scheme changes, and are left out. The iterative algorithm's perturbation goes into its first sweep
(where its loop values enter); its converged steps then make the free response.

For a linear system the differences are exact up to round-off whatever the perturbation's size; for a nonlinear
one they are the linearization along the run (``delta``, relative to each sample's size over the warm-up).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import CosimError
from ..execution import Execution
from ..runtime import SavedPoint

FIXED_STEP = ("jacobi", "gauss-seidel", "iterative")


class IdentificationError(CosimError):
    """The step map could not be identified at this point (it grows too fast to be seen over enough steps, or
    the run is too short); bad input raises CosimError as everywhere."""


@dataclass
class StepMap:
    """The identified step map: its realization ``matrix``, ``eigenvalues`` (largest modulus first) and the
    singular values of the Hankel matrix it was cut from (their fall shows how clear the order ``r`` is)."""
    matrix: np.ndarray
    eigenvalues: np.ndarray
    singular_values: np.ndarray
    settings: dict = field(default_factory=dict)

    @property
    def spectral_radius(self) -> float:
        return float(np.abs(self.eigenvalues[0])) if len(self.eigenvalues) else 0.0

    @property
    def order(self) -> int:
        return len(self.eigenvalues)

    @property
    def fit_residual(self) -> float:
        """How far the realization misses the Markov parameters it was cut from (relative): round-off for a
        linear system, large where the map changes over the identification's steps (a nonlinear system far from
        linear there), whose radius then means little."""
        return float(self.settings.get("fit_residual", float("nan")))


def era(markov: list[np.ndarray], blocks: int, rank_tol: float, spacing: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The realization matrix of Markov parameters ``markov`` (p x m each, Y_k = C S^k B) and the Hankel
    matrix's singular values. ``spacing`` q: the Hankel blocks are q steps apart, H0 = [Y_{(i+j)q}], while H1 =
    [Y_{(i+j)q+1}] is one step on, so the realization is still S's; the spacing keeps the columns of H0 apart when
    a step turns the modes by little (a small step), where q = 1 leaves them nearly parallel."""
    h0 = np.block([[markov[(i + j) * spacing] for j in range(blocks)] for i in range(blocks)])
    h1 = np.block([[markov[(i + j) * spacing + 1] for j in range(blocks)] for i in range(blocks)])
    u, s, vt = np.linalg.svd(h0)
    if not len(s) or s[0] == 0.0:
        return np.zeros((0, 0)), s
    r = int(np.sum(s > rank_tol * s[0]))
    root = 1.0 / np.sqrt(s[:r])
    a = (root[:, None] * (u[:, :r].T @ h1 @ vt[:r].T)) * root[None, :]
    return a, s


def best_realization(markov: list[np.ndarray], blocks: int, rank_tol: float, spacings) -> tuple:
    """(matrix, singular values, spacing) of the spacing whose Hankel matrix separates its rank most clearly
    (the largest ratio of the last kept singular value to the first dropped one)."""
    best = None
    for q in spacings:
        if 2 * (blocks - 1) * q + 1 >= len(markov):
            break
        a, s = era(markov, blocks, rank_tol, q)
        r = a.shape[0]
        gap = s[r - 1] / max(s[r] if r < len(s) else 0.0, 1e-300 * s[0]) if r else 0.0
        if best is None or gap > best[0]:
            best = (gap, a, s, q)
    if best is None:
        raise IdentificationError("too few steps to identify the step map (a step map growing too fast overflows)",
                                  element="--step")
    return best[1], best[2], best[3]


def identify(scenario, *, algorithm: str, step: float, params: dict | None = None, at: float | None = None,
             blocks: int = 6, delta: float = 1e-2, rank_tol: float = 1e-8, spacings=(1, 2, 4, 8, 16),
             **options) -> StepMap:
    """The step map of ``scenario`` run with the fixed-step ``algorithm`` at ``step`` (``options``: the
    algorithm's settings as for ``master.run``, e.g. extrapolation=1, gs_interpolation=1, coupling_tol=1e-12),
    around the communication point ``at`` (default: after max(4, 3 + history) steps)."""
    if algorithm not in FIXED_STEP:
        raise CosimError(f"the step map is identified for the fixed-step algorithms ({', '.join(FIXED_STEP)}), "
                         f"not {algorithm}", element="--algorithm")
    stop_time = (at or 0.0) + step * (2 * (blocks - 1) * max(spacings) + 16)     # the steps it takes, not the SSD's
    ex = Execution(scenario, algorithm=algorithm, step=step, params=params, output=None, native_loop=False,
                   stop_time=stop_time, **options)
    try:
        ex.initialize()
        return _identify(ex, at, blocks, delta, rank_tol, tuple(spacings))
    finally:
        ex.close()


def _identify(ex, at, blocks, delta, rank_tol, spacings) -> StepMap:
    from ..algorithms.extrapolation import coupled_outputs
    alg, rt, st = ex.algorithm, ex.rt, ex.settings
    h, start = st.step, st.start
    extrapolator = getattr(alg, "_extrapolator", None)
    history = extrapolator.history if extrapolator is not None else None
    n0 = int(round((at - start) / h)) if at is not None else max(4, 3 + (history.maxlen if history else 0))
    horizon = 2 * (blocks - 1) * max(spacings) + 2
    if n0 + horizon > st.steps:
        raise IdentificationError(f"the identification needs {n0 + horizon} steps of {h:g} s and the run has "
                                  f"{st.steps}", element="--step")
    out = rt.out["Real"]
    scale = np.zeros(len(out))
    for n in range(n0):
        alg.step(n, start + n * h)
        np.maximum(scale, np.abs(out), out=scale)
    positions, _ = coupled_outputs(rt)
    if not len(positions):
        raise CosimError("the scenario has no coupled Real outputs: there is no coupled step map", element="scenario")
    # a value near 0 over the warm-up (a mass at rest) would get a perturbation lost in its neighbours' round-off
    typical = float(np.sqrt(np.mean(scale[positions] ** 2))) or 1.0
    scale = np.maximum(scale, 1e-1 * typical)
    saved, kept = SavedPoint(rt, start + n0 * h), _copy(history)
    slot = {int(p): k for k, p in enumerate(extrapolator.positions)} if extrapolator is not None else {}

    def trajectory(perturbed: int | None, amount: float) -> np.ndarray:
        saved.restore()
        if history is not None:
            history.clear()
            history.extend(s.copy() for s in kept)
            extrapolator.resync()
        if perturbed is not None:
            out[perturbed] += amount
            if perturbed in slot and history:
                history[0][slot[perturbed]] += amount
        rows = []
        alg.current_step(n0, start + n0 * h)      # the perturbation's step: the algorithm's sweep as compiled
        rows.append(out.copy())
        for k in range(1, horizon):
            if not np.all(np.abs(out) < 1e100 * scale):     # growing without bound: enough seen
                break
            alg.step(n0 + k, start + (n0 + k) * h)
            rows.append(out.copy())
        return np.array(rows)

    try:
        base = trajectory(None, 0.0)
        # outputs and perturbations in units of each value's size: a diagonal change of basis at both ends,
        # which leaves the eigenvalues alone and the Hankel matrix well scaled
        runs = [trajectory(int(p), delta * scale[p]) for p in positions]
    finally:
        saved.release()
    length = min(len(base), *(len(r) for r in runs))
    columns = [(r[:length] - base[:length]) / delta / scale[None, :] for r in runs]
    markov = [np.stack([c[k] for c in columns], axis=1) for k in range(length)]
    finite = next((k for k, y in enumerate(markov) if not np.all(np.isfinite(y))), length)
    a, s, q = best_realization(markov[:finite], blocks, rank_tol, spacings)
    residual = _fit_residual(markov[:finite], a, blocks, q)
    eig = np.linalg.eigvals(a) if a.size else np.zeros(0, dtype=complex)
    eig = eig[np.argsort(-np.abs(eig), kind="stable")]
    names = {p: q for q, p in rt.out_pos.items()}
    return StepMap(a, eig, s, {"algorithm": alg.name, "step": h, "at": start + n0 * h, "blocks": blocks, "spacing": q,
                               "fit_residual": residual,
                               "delta": delta, "perturbed": [names.get(int(p), str(p)) for p in positions]})


def _fit_residual(markov, a, blocks, spacing) -> float:
    """max_k |Y_k - C S^k B| / max_k |Y_k| over the Markov parameters the Hankel matrices used, with B and C
    from the same cut (the first block column of s^1/2 V^T, the first block row of U s^1/2)."""
    if not a.size:
        return 0.0
    p, m = markov[0].shape
    h0 = np.block([[markov[(i + j) * spacing] for j in range(blocks)] for i in range(blocks)])
    u, s, vt = np.linalg.svd(h0)
    r = a.shape[0]
    root = np.sqrt(s[:r])
    c = (u[:p, :r] * root[None, :])
    b = (root[:, None] * vt[:r, :m])
    last = 2 * (blocks - 1) * spacing + 1
    scale = max(float(np.max(np.abs(y))) for y in markov[:last + 1]) or 1.0
    power, worst = np.eye(r), 0.0
    for k in range(last + 1):
        if k % spacing == 0 or k % spacing == 1:
            worst = max(worst, float(np.max(np.abs(markov[k] - c @ power @ b))))
        power = a @ power
    return worst / scale


def _copy(history):
    return [s.copy() for s in history] if history is not None else None


def spectral_radius(scenario, *, algorithm: str, step: float, params: dict | None = None, **options) -> float:
    """The spectral radius of the coupled step map (``identify``): above 1 the scheme amplifies some coupled
    mode at every step, and a run with it diverges."""
    return identify(scenario, algorithm=algorithm, step=step, params=params, **options).spectral_radius


__all__ = ["StepMap", "IdentificationError", "identify", "spectral_radius", "era", "FIXED_STEP"]
