"""FMI 2.0 model-exchange FMUs run as co-simulation components, integrated with fmpy's CVode.

Supported: continuous states, time events, state events (CVode root finding), step events, inputs held
constant over each communication step (the solver is re-initialised at every step because a changed
input is a discontinuity). Not supported: FMUs that request terminateSimulation (reported as an error)
and FMI 3.0 model exchange (reported when the scenario is loaded).
"""
from __future__ import annotations

from ..errors import FmuError
from .fmi2 import Fmi2Slave
from .fmpy_adapter import cvode_solver
from .slave import ERROR, OK


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

    @staticmethod
    def _fmi_kind(fmu):
        return fmu.md.modelExchange

    def _instantiate_call(self):
        return 0  # fmi2ModelExchange

    def _event_iteration(self, t):
        m = self.lib.obj
        while True:
            try:
                (new_needed, terminate, nominals_changed, values_changed,
                 next_defined, next_time) = m.newDiscreteStates()
            except Exception:
                raise self.fail("fmi2NewDiscreteStates", ERROR, t) from None
            if terminate:
                raise FmuError("the model requested termination (terminateSimulation), which a component of a "
                               "co-simulation cannot do", file=self.shown_as, element=f"component {self.name}", time=t)
            if not new_needed:
                break
        self.next_event = next_time if next_defined else None

    def exit_init(self, t):
        super().exit_init(t)
        self._event_iteration(t)
        self.lib.obj.enterContinuousTimeMode()
        self.solver = cvode_solver(self.lib.obj, self.nx, self.nz, t, self.rtol)
        self.time = t

    def bound_step(self):
        return self.do_step

    @property
    def raw_step(self):
        return None

    def do_step(self, t, h) -> int:
        m = self.lib.obj
        t_end = t + h
        time = t
        try:
            self.solver.reset(time)
            while time < t_end and abs(time - t_end) > 1e-13 * max(1.0, abs(t_end)):
                t_next = t_end
                if self.next_event is not None and time < self.next_event < t_end:
                    t_next = self.next_event
                state_event, _roots, time = self.solver.step(time, t_next)
                m.setTime(time)
                step_event, terminate = m.completedIntegratorStep()
                if terminate:
                    raise FmuError("the model requested termination", file=self.shown_as,
                                   element=f"component {self.name}", time=time)
                time_event = self.next_event is not None and time >= self.next_event
                if state_event or step_event or time_event:
                    m.enterEventMode()
                    self._event_iteration(time)
                    m.enterContinuousTimeMode()
                    self.solver.reset(time)
            m.setTime(t_end)
        except FmuError:
            raise
        except Exception as exc:
            self.log.message(self.name, "error", f"integration failed: {' '.join(str(exc).split())}")
            return ERROR
        return OK
