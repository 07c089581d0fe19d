"""FMI 3.0 model-exchange FMUs as co-simulation components: the stepping of ``model_exchange.ModelExchange``
over the values, ports and life cycle of the FMI 3.0 co-simulation class (typed variables, arrays)."""
from __future__ import annotations

import numpy as np

from .fmi3 import Fmi3Slave
from .fmpy_adapter import fmi3_callbacks, load_library
from .model_exchange import ModelExchange
from .ode_solvers import SolverChoice
from .slave import ERROR, Slave, array_shape

FLOAT_TYPES = ("Float64", "Float32")


class Fmi3MeSlave(ModelExchange, Fmi3Slave):
    _UPDATE_DISCRETE = ("updateDiscreteStates", "fmi3UpdateDiscreteStates")

    def __init__(self, name, fmu, log, shown_as, logging_on=False, solver: SolverChoice | None = None):
        # Fmi3Slave.__init__ loads the co-simulation binary; the variable tables are the same
        Slave.__init__(self, name, fmu, log, shown_as)
        self.lib = self._f = load_library("fmi3me", name, fmu, shown_as, fmu.md.modelExchange.modelIdentifier)
        self.logging_on = logging_on
        self.c = None
        by_vr = {v.valueReference: v for v in fmu.md.modelVariables}
        self._vtype = {vr: v.type for vr, v in by_vr.items()}
        self._nvalues = {vr: int(np.prod(array_shape(v, by_vr))) for vr, v in by_vr.items()}
        self._init_model_exchange(solver)

    def instantiate(self):
        # fmi3InstantiateModelExchange has no intermediate-update callback
        self._log_cb, _ = fmi3_callbacks(self._logger_fn())
        resources = str(self.fmu.unzip_dir / "resources") + "/"
        comp = self._f["fmi3InstantiateModelExchange"](
            self.name.encode(), self.fmu.md.guid.encode(), resources.encode(), False, self.logging_on, None,
            self._log_cb)
        if not comp:
            raise self.fail("fmi3InstantiateModelExchange", ERROR)
        self.c = comp
        self.lib.bind_instance(comp)
        self.instantiated = True

    def _discrete_vrs(self) -> set[int]:
        return {int(v.valueReference) for v in self.fmu.md.modelVariables
                if v.type not in FLOAT_TYPES or v.variability != "continuous"}

    def _state_counts(self) -> tuple[int, int]:
        """Counted by the instance: array states take their size from structural parameters."""
        m = self.lib.obj
        return m.getNumberOfContinuousStates(), m.getNumberOfEventIndicators()

    def _derivatives_call(self):
        return self.lib.obj.getContinuousStateDerivatives
