"""The event iteration FMI 2.0 and 3.0 share, for model exchange and for FMI 3.0 co-simulation in event mode:
update the discrete states until the model needs no new ones (FMI 3.0 fmi3UpdateDiscreteStates, FMI 2.0
fmi2NewDiscreteStates)."""
from __future__ import annotations

from ..errors import FmuError
from .slave import ERROR

# FMI asks the importer to iterate while the FMU needs new discrete states; an FMU that never settles would hang
# the run, so after this many passes it is reported as a defect of the FMU
MAX_PASSES = 1000


def settle(slave, update, call: str, t: float) -> tuple[bool, float | None]:
    """Call ``update`` (fmpy's updateDiscreteStates or newDiscreteStates of ``slave``'s instance; ``call`` is
    the FMI function's name for messages) until the model needs no new discrete states. Returns (terminate,
    next event time or None): terminate is true when the model asks to end the simulation."""
    for _ in range(MAX_PASSES):
        try:
            new_needed, terminate, _nominals_changed, _values_changed, next_defined, next_time = update()
        except Exception:
            raise slave.fail(call, ERROR, t) from None
        if terminate:
            return True, None
        if not new_needed:
            return False, (next_time if next_defined else None)
    raise FmuError(f"{call}: the event iteration did not settle after {MAX_PASSES} passes (the FMU kept asking "
                   "for new discrete states)", file=slave.shown_as, element=f"component {slave.name}", time=t)
