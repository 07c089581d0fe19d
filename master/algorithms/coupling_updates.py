"""How iterative coupling forms its next iterate of the coupled values from the last one, u, and what the
FMUs made of it, G(u) (residual r = G(u) - u). Each update starts afresh every macro step (``start``).

- ``fixed-point``: u <- G(u). Converges when the coupling iteration contracts (spectral radius of G' below 1).
- ``aitken``: u <- u + w r with Aitken's dynamic relaxation factor, w_k = -w_{k-1} r_{k-1}.(r_k - r_{k-1}) /
  |r_k - r_{k-1}|^2 (Irons and Tuck 1969; Kuettler and Wall 2008; as preCICE's "aitken"), w_0 = 0.5.
- ``iqn-ils``: interface quasi-Newton with an inverse Jacobian from least squares (Degroote, Bathe and
  Vierendeels 2009; preCICE, Uekermann 2016): columns V of residual differences and W of output differences
  within the step; alpha = argmin |V alpha + r|, u <- G(u) + W alpha. For a linear G of n coupled values it
  reaches the fixed point after at most n + 1 evaluations (up to round-off); the first update relaxes by 0.5.
"""
from __future__ import annotations

import numpy as np

INITIAL_RELAXATION = 0.5      # the first relaxed step of aitken and iqn-ils (preCICE's usual initial value)


class FixedPoint:
    name = "fixed-point"

    def start(self) -> None:
        pass

    def next(self, u: np.ndarray, g: np.ndarray) -> np.ndarray:
        return g


class Aitken:
    name = "aitken"

    def start(self) -> None:
        self.omega = INITIAL_RELAXATION
        self.last_residual = None

    def next(self, u: np.ndarray, g: np.ndarray) -> np.ndarray:
        r = g - u
        if self.last_residual is not None:
            change = r - self.last_residual
            size = change @ change
            if size > 0.0:       # zero: the residual did not change; keep the factor
                self.omega = -self.omega * (self.last_residual @ change) / size
        self.last_residual = r
        return u + self.omega * r


class IqnIls:
    name = "iqn-ils"

    def start(self) -> None:
        self.residual_changes: list[np.ndarray] = []      # V, newest first
        self.output_changes: list[np.ndarray] = []        # W, newest first
        self.last = None

    def next(self, u: np.ndarray, g: np.ndarray) -> np.ndarray:
        r = g - u
        if self.last is not None:
            last_r, last_g = self.last
            self.residual_changes.insert(0, r - last_r)
            self.output_changes.insert(0, g - last_g)
            # more columns than coupled values are linearly dependent: keep the newest
            del self.residual_changes[len(u):], self.output_changes[len(u):]
        self.last = (r, g)
        if not self.residual_changes:
            return u + INITIAL_RELAXATION * r
        V = np.column_stack(self.residual_changes)
        W = np.column_stack(self.output_changes)
        alpha = np.linalg.lstsq(V, -r, rcond=None)[0]
        return g + W @ alpha


UPDATES = {cls.name: cls for cls in (FixedPoint, Aitken, IqnIls)}
