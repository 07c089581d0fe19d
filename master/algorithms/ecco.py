"""ECCO, energy-conservation-based co-simulation (Sadjina, Kyllingstad, Skjong and Pedersen 2017), as
libcosim's ``ecco_algorithm``: non-iterative steps whose size follows the power residual of the power bonds.

For a bond between X and Y (ssp/power_bonds.py: Y's effort output feeds X, X's flow output feeds Y) the power
seen by each side after a step, from its own held input and its new output, is P_X = e_in,X f_out,X and
P_Y = e_out,Y f_in,Y. Continuous coupling would make them equal; a step with held inputs leaves the power
residual dP = P_X - P_Y, which times the step is energy the coupling created or destroyed. libcosim's error
estimate per step (its ``adjust_step_size``), per bond:

    eps_b = |dP h| / (atol + rtol |max(P_X, P_Y) h|),   eps = sqrt(mean_b eps_b^2)

(libcosim sums the powers of all bonds before this; for one bond the two agree), and its controller
h_next = clamp(safety eps^-(k_I + k_P) eps_prev^k_P, min_rate, max_rate) h, then [min step, max step],
keeping h when eps or eps_prev is 0 (step_control.PIController with keep_on_zero). Parameters as in libcosim's
ECCO test system (quarter truck): safety 0.99, rates 0.2..1.5, k_P = 0.2, k_I = 0.15. Like libcosim no step
is rejected (Sadjina et al.: "non-iterative"), so no FMU needs to roll back.

The steps are adaptive.py's: Jacobi, inputs held (or extrapolated with --extrapolation), each master step's
end hit exactly. steps.csv gets per bond the powers, the power residual and the energy residual summed over
the run, run.json the largest power residual and the final energy residual per bond.
"""
from __future__ import annotations

import numpy as np

from ..errors import CosimError
from ..ssp.power_bonds import POWER_BONDS_TYPE, read_power_bonds
from . import ALGORITHMS
from .adaptive import Adaptive
from .step_control import PIController

LIBCOSIM_GAINS = {"safety": 0.99, "min_rate": 0.2, "max_rate": 1.5, "k_p": 0.2, "k_i": 0.15}


@ALGORITHMS.register("ecco")
class Ecco(Adaptive):
    name = "ecco"
    loop_treatment = ("ecco sweeps in Jacobi fashion inside each of its steps, so the loop delays values by one "
                      "of its steps")
    rejects = False
    defaults = {"step_rtol": 1e-4, "min_step_ratio": 1e-3, "initial_ratio": 0.1}

    def configure(self, options) -> None:
        super().configure(options)
        if getattr(options, "error_estimate", None) is not None:
            raise CosimError("--error-estimate does not apply to ecco (its estimate is the power residual)",
                             element="--error-estimate")
        self.estimate = "power residual"

    def prepare(self, rt, plan, h: float) -> dict:
        self.bonds = read_power_bonds(plan)
        if not self.bonds:
            raise CosimError(f"ecco needs power bonds, and the SSD declares none (an annotation of type "
                             f"{POWER_BONDS_TYPE}: docs/coupling.md)", file=plan.shown_as, element="--algorithm ecco")
        out_pos = rt.out_pos
        # positions in out["Real"] of e_out,Y and f_out,X, and the effort connection's affine map (a unit
        # conversion): both powers are taken in X's units, P_Y as T(e_out,Y) times the flow X sent (= f_in,Y)
        self._effort_out = np.array([out_pos[b.effort.src.qualified] for b in self.bonds], dtype=np.intp)
        self._flow_out = np.array([out_pos[b.flow.src.qualified] for b in self.bonds], dtype=np.intp)
        self._effort_map = (np.array([b.effort.factor for b in self.bonds]),
                            np.array([b.effort.offset for b in self.bonds]))
        self.energy_residual = np.zeros(len(self.bonds))
        self.power_residual_max = np.zeros(len(self.bonds))
        info = super().prepare(rt, plan, h)
        g = LIBCOSIM_GAINS
        self.controller = PIController(k_i=g["k_i"], k_p=g["k_p"], safety=g["safety"], min_rate=g["min_rate"],
                                       max_rate=g["max_rate"], h_min=self.limits.h_min, h_max=self.limits.h_max,
                                       keep_on_zero=True, r_prev=0.0)
        info.update({"controller": "libcosim ecco: " + ", ".join(f"{k} {v}" for k, v in g.items()),
                     "power_bonds": {b.name: {"effort": f"{b.effort.src.qualified} -> {b.effort.dst.qualified}",
                                              "flow": f"{b.flow.src.qualified} -> {b.flow.dst.qualified}"}
                                     for b in self.bonds}})
        return info

    def _inputs_held(self) -> None:
        out = self.rt.out["Real"]
        factor, offset = self._effort_map
        self._effort_in = out[self._effort_out] * factor + offset     # e_in,X: what X holds over the step
        self._flow_in = out[self._flow_out].copy()                    # f_in,Y, in X's units

    def _attempt(self, n: int, t: float, h: float, first: bool, saved) -> tuple[float, float, tuple]:
        self._sweep(n, t, h, first)
        out = self.rt.out["Real"]
        factor, offset = self._effort_map
        p_x = self._effort_in * out[self._flow_out]
        p_y = (out[self._effort_out] * factor + offset) * self._flow_in
        residual = p_x - p_y
        self.energy_residual += residual * h
        np.maximum(self.power_residual_max, np.abs(residual), out=self.power_residual_max)
        level = np.maximum(p_x, p_y) * h
        eps = np.abs(residual * h) / (self.limits.atol + self.limits.rtol * np.abs(level))
        r = float(np.sqrt(np.mean(eps ** 2)))
        extra = tuple(v for b in range(len(self.bonds))
                      for v in (p_x[b], p_y[b], residual[b], self.energy_residual[b]))
        return r, 1.0, extra

    def _set_gains(self, q: float) -> None:
        pass            # libcosim's gains are fixed

    def step_columns(self) -> list[str]:
        return super().step_columns() + [f"{b.name}.{c}" for b in self.bonds
                                         for c in ("power_a", "power_b", "power_residual", "energy_residual")]

    def finish(self, out_dir) -> dict:
        return {**super().finish(out_dir),
                "energy_residual": {b.name: float(e) for b, e in zip(self.bonds, self.energy_residual)},
                "power_residual_max": {b.name: float(p) for b, p in zip(self.bonds, self.power_residual_max)}}
