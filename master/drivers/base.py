"""What a step driver is: an accelerator of the step loop, ``Execution._steps``, and of the algorithm step it calls.

The reference is ``Execution._steps`` (read it first): per step, the manipulators, the algorithm's step, the
observers, the finiteness check, an early end when an FMU or an observer asks, a shorter final step, the progress
bar.  A driver runs a stretch of full-length steps of one execution with exactly the same effect, bit for bit: the
same values in the same buffers, the same rows recorded, the same ``Execution.n``, ``metadata["last_time"]``,
``metadata["ended_early"]``, doStep counts (``Runtime.do_step_calls``) and errors, also when it stops early or
raises.  ``Execution._steps`` asks the drivers in one place (``master.drivers.driver_for``), once per execution;
``COSIM_MASTER_PURE_PYTHON=1`` (``master.accel.enabled``) and ``Options.native_loop=False`` (``--no-native-loop``)
switch them all off.

A new driver implements :class:`StepDriver` (``why_not`` and ``bind``), returns a :class:`DriverRun` from
``bind``, is listed in ``master.drivers.DRIVERS`` and is published under the ``cosim_master.accelerators`` entry
point group with cases (see ``master/step_accelerators.py``), so that ``tests/accelerators/`` checks it against the
reference loop.  It reads only public properties, and writes only those marked (w):

- ``Execution``: ``settings`` (``start``, ``step``, ``steps``), ``options`` (``allow_nonfinite``), ``n`` (w: the
  steps done), ``metadata`` (w: ``last_time``, ``ended_early``, its own key), ``observers``, ``manipulators``,
  ``recording``, ``algorithm``, ``rt``;
- ``Algorithm``: ``order``, ``gauss_seidel``, ``h``, ``threads``, ``feeds_inputs`` and its class;
- ``Runtime``: ``slaves``, ``names``, ``active``, ``multiple``, ``xfer``, ``write_ports``, ``read_ports``,
  ``sample_ports``, ``staging``, ``out``, ``real_zeros``, ``do_step_calls`` (w), ``stop_reason``,
  ``ends_run_on_request``, ``nonfinite_error``;
- ``Recording``: ``samples_after(n)`` (when a row is taken), ``every``, ``steps``, ``block``, ``block_rows``,
  ``fill`` (w), ``gather``, ``has_object_columns``, ``flush()``, ``after_step``, and a supervised child's
  ``native_progress()``;
- a slave: ``c`` (its instance), ``raw_function(name)`` (a native slave's C functions), ``raw_step``,
  ``event_mode``, ``early_return``, ``terminate_requested``, FMI 3.0's ``step_cells``, ``may_roll_back`` and
  ``after_do_step``, ``fail``; a port's ``vrs``, ``n``, ``buf``, ``extra``.
"""
from __future__ import annotations

from typing import Protocol


class DriverRun(Protocol):
    """A driver bound to one execution (made once, after initialization); ``name`` is its driver's."""

    name: str

    def advance(self, n: int, end: int, bar=None) -> None:
        """Steps ``n`` .. ``end``-1, all of the master step's full length (the shorter final step is the
        reference loop's), or fewer when the run ends early (``rt.stop_reason`` set) or a step fails (raising as
        the reference does). ``Execution.n`` and ``metadata["last_time"]`` follow every step, also when this
        raises; ``bar`` (a tqdm bar or None) is updated by the steps done."""


class StepDriver(Protocol):
    """A step driver: ``name`` is its key in run.json (``{"used": true, "steps": k}`` or ``{"used": false,
    "reason": ...}``)."""

    name: str

    def why_not(self, ex) -> str | None:
        """None when this driver can run the steps of the initialized execution ``ex``, else why not (one line,
        for run.json)."""

    def bind(self, ex) -> DriverRun:
        """The driver for ``ex`` (called only when ``why_not(ex)`` is None)."""
