"""Model-exchange FMUs run as co-simulation components on an ODE solver (``ode_solvers``: CVode BDF or
Adams, or fixed-step forward Euler).

Supported: continuous states, time events, state events (CVode root finding; Euler: a sign change over an
internal step), step events, inputs held constant over each communication step (the solver is re-initialised
at every step because a changed input is a discontinuity), discrete inputs (FMI lets them change in event mode
only: a changed one starts an event at the beginning of the step), and terminateSimulation (the run ends after
the step, as when a monitor stops it).

``ModelExchange`` holds the semantics, which FMI 2.0 and 3.0 share call for call; a version's class adds the
few calls that differ in name (:class:`Fmi2MeSlave` here, ``Fmi3MeSlave`` in ``model_exchange3``) and
inherits values, ports and the life cycle from that version's co-simulation class.
"""
from __future__ import annotations

import types

import numpy as np

from ..errors import FmuError
from .fmi2 import Fmi2Slave
from .events import settle
from .ode_solvers import DEFAULT_RTOL, SolverChoice, make_solver
from .slave import DISCARD, ERROR, OK


def _ok():
    return OK


class ModelExchange:
    """The model-exchange stepping shared by FMI 2.0 and 3.0, mixed in before a version's slave class. A
    version's class provides ``_discrete_vrs()``, ``_state_counts()``, ``_derivatives_call()`` and names its
    discrete-state update (``_UPDATE_DISCRETE``: fmpy's method, C function)."""
    kind = "ModelExchange"
    _UPDATE_DISCRETE: tuple[str, str]

    def _init_model_exchange(self, solver: SolverChoice | None) -> None:
        # rollback would also need the solver's state: not offered for model exchange
        self.can_save_state = False
        self.solver_choice = solver or SolverChoice()
        self.rtol = DEFAULT_RTOL
        self.solver = None
        self.terminate_requested = False
        self.events = dict.fromkeys(("time", "state", "step", "input"), 0)
        # FMI sets discrete variables (all but continuous floating-point ones) in initialization and event mode
        self._discrete = self._discrete_vrs()
        self._held: dict[int, tuple] = {}      # id(port) -> (type, port): discrete inputs set at an event
        self._sent: dict[int, np.ndarray] = {}   # id(port) -> the values the FMU has
        self._held_values: dict[tuple, object] = {}   # (type, vr) -> a discrete value set after initialization

    def setup(self, start, stop, tolerance=None):
        """``tolerance``: the command line's or the FMU's DefaultExperiment's (Runtime.instantiate), the
        solver's relative tolerance too."""
        self.rtol = tolerance or DEFAULT_RTOL
        super().setup(start, stop, tolerance)

    def _event_iteration(self, t) -> bool:
        """Update discrete states until the model has settled; True when it asks to terminate the simulation."""
        method, call = self._UPDATE_DISCRETE
        terminate, self.next_event = settle(self, getattr(self.lib.obj, method), call, t)
        return terminate

    def exit_init(self, t):
        super().exit_init(t)
        self.time = t
        if self._event_iteration(t):
            self.terminate_requested = True     # the first do_step reports it
            return
        self.lib.obj.enterContinuousTimeMode()
        nx, nz = self._state_counts()
        self.solver = make_solver(self.solver_choice, self._solver_calls(), nx, nz, t, self.rtol)

    def _solver_calls(self):
        """The model's functions in the form the solvers call them (fmpy's methods)."""
        m = self.lib.obj
        return types.SimpleNamespace(get_x=m.getContinuousStates, set_x=m.setContinuousStates,
                                     get_dx=self._derivatives_call(), get_z=m.getEventIndicators,
                                     get_nominals=m.getNominalsOfContinuousStates, set_time=m.setTime)

    def stats(self) -> dict:
        """The solver and what it did, for run.json (empty before the solver started)."""
        if self.solver is None:
            return {}
        return {"solver": self.solver_choice.name, "relative_tolerance": self.rtol,
                **({"internal_step": self.solver_choice.step} if self.solver_choice.name == "euler" else {}),
                **self.solver.stats(), "events": sum(self.events.values()),
                **{f"{kind}_events": n for kind, n in self.events.items()}}

    # -- discrete inputs: held until the next step starts, then set in event mode ---------------------------
    def _is_discrete(self, port) -> bool:
        return any(int(vr) in self._discrete for vr in port.vrs)

    def set_port(self, typ, port) -> int:
        if not self._is_discrete(port):
            return super().set_port(typ, port)
        if self.solver is not None:           # continuous-time mode: wait for the next step's event
            self._held[id(port)] = (typ, port)
            return OK
        self._sent[id(port)] = port.buf.copy()
        return super().set_port(typ, port)

    def bound_set(self, typ, port):
        if not self._is_discrete(port):
            return super().bound_set(typ, port)
        self._held[id(port)] = (typ, port)
        return _ok

    def set_value(self, typ, vr, value):
        if self.solver is not None and int(vr) in self._discrete:
            self._held_values[(typ, int(vr))] = value
            return OK
        return super().set_value(typ, vr, value)

    def _changed_discrete_inputs(self) -> list:
        return [(typ, port) for key, (typ, port) in self._held.items()
                if key not in self._sent or not np.array_equal(self._sent[key], port.buf)]

    def _set_discrete_inputs(self, changed, t) -> bool:
        """An event at t for changed discrete inputs (FMI allows setting them in event mode only);
        True when the model then asks to terminate the simulation."""
        m = self.lib.obj
        m.enterEventMode()
        for typ, port in changed:
            self.check(f"setting discrete inputs ({typ})", super().set_port(typ, port), t)
            self._sent[id(port)] = port.buf.copy()
        for (typ, vr), value in self._held_values.items():
            self.check(f"setting discrete variable {vr} ({typ})", super().set_value(typ, vr, value), t)
        self._held_values.clear()
        if self._event_iteration(t):
            return True
        m.enterContinuousTimeMode()
        return False

    # -- stepping ---------------------------------------------------------------------------------------------
    def bound_step(self):
        return self.do_step

    @property
    def raw_step(self):
        return None

    def asks_to_terminate(self, status: int) -> bool:
        return status == DISCARD and self.terminate_requested

    def _terminating(self) -> int:
        """The model asked to terminate the simulation: the step ends here (reported as Discard)."""
        self.terminate_requested = True
        return DISCARD

    def do_step(self, t, h) -> int:
        if self.terminate_requested:
            return DISCARD
        try:
            if self._inputs_end_simulation(t) or self._integrate(t, t + h):
                return self._terminating()
        except FmuError:
            raise
        except Exception as exc:
            self.log.message(self.name, "error", f"integration failed: {' '.join(str(exc).split())}")
            return ERROR
        return OK

    def _inputs_end_simulation(self, t) -> bool:
        """Discrete inputs that changed since the last step start an event at t; True when the model then asks
        to terminate the simulation."""
        changed = self._changed_discrete_inputs() if self._held else ()
        if not (changed or self._held_values):
            return False
        self.events["input"] += 1
        return self._set_discrete_inputs(changed, t)

    def _integrate(self, t, t_end) -> bool:
        """From t to t_end with the inputs held, handling the events on the way; True when the model asks to
        terminate the simulation."""
        m = self.lib.obj
        time = t
        self.solver.reset(time)
        while time < t_end and abs(time - t_end) > 1e-13 * max(1.0, abs(t_end)):
            t_next = t_end
            if self.next_event is not None and time < self.next_event < t_end:
                t_next = self.next_event
            state_event, _roots, time = self.solver.step(time, t_next)
            m.setTime(time)
            step_event, terminate = m.completedIntegratorStep()
            if terminate:
                return True
            causes = {"time": self.next_event is not None and time >= self.next_event,
                      "state": bool(state_event), "step": bool(step_event)}
            if any(causes.values()) and self._event(time, causes):
                return True
        m.setTime(t_end)
        return False

    def _event(self, time, causes: dict) -> bool:
        """An event at ``time`` (``causes``: which kinds, counted for the statistics); True when the model asks
        to terminate the simulation."""
        for kind, happened in causes.items():
            self.events[kind] += happened
        m = self.lib.obj
        m.enterEventMode()
        if self._event_iteration(time):
            return True
        m.enterContinuousTimeMode()
        self.solver.reset(time)
        return False


class Fmi2MeSlave(ModelExchange, Fmi2Slave):
    _library_kind = "fmi2me"
    _UPDATE_DISCRETE = ("newDiscreteStates", "fmi2NewDiscreteStates")

    def __init__(self, name, fmu, log, shown_as, logging_on=False, solver: SolverChoice | None = None):
        super().__init__(name, fmu, log, shown_as, logging_on)
        self._init_model_exchange(solver)

    @staticmethod
    def _fmi_kind(fmu):
        return fmu.md.modelExchange

    def _instantiate_call(self):
        return 0  # fmi2ModelExchange

    def _discrete_vrs(self) -> set[int]:
        return {int(v.valueReference) for v in self.fmu.md.modelVariables
                if v.type != "Real" or v.variability != "continuous"}

    def _state_counts(self) -> tuple[int, int]:
        md = self.fmu.md
        return md.numberOfContinuousStates, md.numberOfEventIndicators

    def _derivatives_call(self):
        return self.lib.obj.getDerivatives
