"""FMI 2.0 model-exchange FMUs run as co-simulation components, integrated with fmpy's CVode.

Supported: continuous states, time events, state events (CVode root finding), step events, inputs held
constant over each communication step (the solver is re-initialised at every step because a changed
input is a discontinuity), discrete inputs (FMI 2.0 lets them change in event mode only: a changed one
starts an event at the beginning of the step), and terminateSimulation (the run ends after the step, as
when a monitor stops it). Not supported: FMI 3.0 model exchange (reported when the scenario is loaded).
"""
from __future__ import annotations

import numpy as np

from ..errors import FmuError
from .fmi2 import Fmi2Slave
from .fmpy_adapter import cvode_solver
from .slave import DISCARD, ERROR, OK


def _ok():
    return OK


class Fmi2MeSlave(Fmi2Slave):
    kind = "ModelExchange"
    _library_kind = "fmi2me"

    def __init__(self, name, fmu, log, shown_as, logging_on=False, rtol=1e-10):
        super().__init__(name, fmu, log, shown_as, logging_on)
        # rollback would also need the solver's state: not offered for model exchange
        self.can_save_state = False
        self.rtol = rtol
        self.nx = fmu.md.numberOfContinuousStates
        self.nz = fmu.md.numberOfEventIndicators
        self.solver = None
        self.terminate_requested = False
        # FMI 2.0 sets discrete variables (all but continuous Reals) in initialization and event mode only
        self._discrete = {int(v.valueReference) for v in fmu.md.modelVariables
                          if v.type != "Real" or v.variability != "continuous"}
        self._held: dict[int, tuple] = {}      # id(port) -> (type, port): discrete inputs set at an event
        self._sent: dict[int, np.ndarray] = {}   # id(port) -> the values the FMU has
        self._held_values: dict[tuple, object] = {}   # (type, vr) -> a discrete value set after initialization

    @staticmethod
    def _fmi_kind(fmu):
        return fmu.md.modelExchange

    def _instantiate_call(self):
        return 0  # fmi2ModelExchange

    def _event_iteration(self, t) -> bool:
        """fmi2NewDiscreteStates until the model has settled; True when it asks to terminate the simulation."""
        m = self.lib.obj
        while True:
            try:
                (new_needed, terminate, nominals_changed, values_changed,
                 next_defined, next_time) = m.newDiscreteStates()
            except Exception:
                raise self.fail("fmi2NewDiscreteStates", ERROR, t) from None
            if terminate:
                return True
            if not new_needed:
                break
        self.next_event = next_time if next_defined else None
        return False

    def exit_init(self, t):
        super().exit_init(t)
        self.time = t
        if self._event_iteration(t):
            self.terminate_requested = True     # the first do_step reports it
            return
        self.lib.obj.enterContinuousTimeMode()
        self.solver = cvode_solver(self.lib.obj, self.nx, self.nz, t, self.rtol)

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
        """An event at t for changed discrete inputs (FMI 2.0 allows setting them in event mode only);
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
        m = self.lib.obj
        t_end = t + h
        time = t
        try:
            changed = self._changed_discrete_inputs() if self._held else ()
            if (changed or self._held_values) and self._set_discrete_inputs(changed, t):
                return self._terminating()
            self.solver.reset(time)
            while time < t_end and abs(time - t_end) > 1e-13 * max(1.0, abs(t_end)):
                t_next = t_end
                if self.next_event is not None and time < self.next_event < t_end:
                    t_next = self.next_event
                state_event, _roots, time = self.solver.step(time, t_next)
                m.setTime(time)
                step_event, terminate = m.completedIntegratorStep()
                if terminate:
                    return self._terminating()
                time_event = self.next_event is not None and time >= self.next_event
                if state_event or step_event or time_event:
                    m.enterEventMode()
                    if self._event_iteration(time):
                        return self._terminating()
                    m.enterContinuousTimeMode()
                    self.solver.reset(time)
            m.setTime(t_end)
        except FmuError:
            raise
        except Exception as exc:
            self.log.message(self.name, "error", f"integration failed: {' '.join(str(exc).split())}")
            return ERROR
        return OK
