"""Run an SSP with libcosim (via libcosimpy) as an independent peer master.

``run_libcosim(ssp_path, step, stop_time, variables)`` loads the SSP with
``CosimExecution.from_ssp_file``, records the requested variables at every
communication point and returns a ``pandas.DataFrame`` with the columns
``time`` and ``"<component>.<variable>"``.

What libcosim does (libcosimpy 0.0.6 bundles libcosim/libcosimc 0.11.2).
Evidence: libcosim sources ``src/cosim/algorithm/fixed_step_algorithm.cpp``,
``src/cosim/slave_simulator.cpp``, ``src/cosim/execution.cpp``,
``src/cosim/observer/time_series_observer.cpp``, ``src/cosim/ssp/ssp_parser.cpp``,
``src/cosim/ssp/ssp_loader.cpp`` and ``src/cosim/fmi/v2/fmu.cpp``
(open-simulation-platform/libcosim), and confirmed numerically by
``tests/test_libcosim_peer.py`` which reproduces libcosim's trajectories to
round-off with ``analytic.chain_recurrence(method="jacobi_delayed")`` and
``analytic.two_mass_cosim(method="jacobi_delayed")``.

* Value caches.  Every slave has a *get cache* and a *set cache*.
  ``slave_simulator::do_step`` is ``set_variables(); slave->do_step(t, h);
  get_variables();``: the cached inputs are written to the FMU (fmi2SetXXX)
  right before fmi2DoStep, and all exposed outputs are read (fmi2GetXXX) right
  after it.  Reading a connection source returns the cached value; setting a
  connection target only writes the set cache.
* Stepping (``fixed_step_algorithm::do_step``): all slaves step in parallel
  (thread pool) from the same time t with step h; afterwards
  ``calculate_and_transfer()`` copies, for every connection, the source's
  cached output into the target's set cache.  So a connected value is
  delivered to the input *before the next step* (it is applied at the start
  of the next ``do_step``), i.e. Jacobi with zero-order hold.
* Consequence for direct feedthrough: an output is read only right after its
  own doStep, before the newly transferred inputs are applied, so a
  feedthrough output (e.g. Gain.y = k u, MassB.F) seen by the other slaves
  and by observers at step n+1 reflects the input applied during step n:
  every feedthrough in a connection path adds one step of delay.  This is
  ``analytic``'s ``"jacobi_delayed"`` method.
* Initialization (``fixed_step_algorithm::initialize``): (1) start/parameter
  values from the SSP parameter set are applied to every slave while it is
  in the instantiated state; (2) ``setup``: fmi2SetupExperiment +
  fmi2EnterInitializationMode, then the outputs are read; (3) N =
  (#slaves + #functions) iterations of {write cached inputs, read outputs}
  for every slave followed by a transfer of all connections -- propagating
  initial values through feedthrough chains of length < N; (4)
  ``start_simulation``: write cached inputs, fmi2ExitInitializationMode,
  read outputs; then one more transfer.
* Values at t = start: the execution initializes lazily inside its first
  ``step()`` and then notifies the observers (``simulation_initialized``);
  the time-series observer records step 0 there.  So the row at t = 0 holds
  the outputs read right after fmi2ExitInitializationMode (after the
  initialization iterations), i.e. *after* initialization.  Row n holds the
  outputs read right after the n-th doStep (``simulator_step_complete``).
* SSP specifics: elements are looked up with literal ``ssd:``/``ssc:``/
  ``ssv:`` prefixes; parameter sets may be inline (``ssd:ParameterValues``)
  or external ``.ssv`` files referenced relative to the SSD; only the first
  parameter set of a component is applied by default; the step size comes
  from the ``osp:FixedStepAlgorithm baseStepSize`` annotation of
  ``ssd:DefaultExperiment`` unless given explicitly (we always pass it).
  Components are kept in an unordered map, so slave indices do not follow
  the SSD order (we look them up by instance name).
* libcosim's FMI 2.0 importer passes ``fmuResourceLocation = NULL`` to
  fmi2Instantiate (v2/fmu.cpp), so FMUs that rely on it may fail; the
  pythonfmu test FMUs nevertheless run (checked in test_libcosim_peer.py).
  An SSP with an FMI 3.0 FMU fails to load in this libcosim (checked).
* A doStep returning fmi2Discard makes the step fail ("Step not complete");
  fmi2Error throws a model error; both stop the execution.
"""

from __future__ import annotations

import ctypes
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

NANO = 1_000_000_000


def _to_nanos(seconds: float) -> int:
    return int(round(float(seconds) * NANO))


def _samples(observer, slave_index: int, vr: int, n: int, integer: bool):
    """Read n samples starting at step 0 from a time-series observer.

    Calls libcosimc directly: libcosimpy 0.0.6 trims its result by counting
    zero step numbers, which also drops the legitimate sample of step 0.
    """
    from libcosimpy._internal import libcosimc

    lib = libcosimc()
    ctype = ctypes.c_int if integer else ctypes.c_double
    fname = "cosim_observer_slave_get_integer_samples" if integer else "cosim_observer_slave_get_real_samples"
    fn = getattr(lib, fname)
    values = (ctype * n)()
    steps = (ctypes.c_int64 * n)()
    times = (ctypes.c_int64 * n)()
    fn.argtypes = [
        ctypes.c_void_p,
        ctypes.c_int,
        ctypes.c_uint32,
        ctypes.c_int64,
        ctypes.c_size_t,
        ctype * n,
        ctypes.c_int64 * n,
        ctypes.c_int64 * n,
    ]
    fn.restype = ctypes.c_int64
    ptr = ctypes.cast(observer.ptr(), ctypes.c_void_p)
    got = fn(ptr, slave_index, vr, 0, n, values, steps, times)
    if got < 0:
        raise RuntimeError(f"libcosim could not read samples for slave {slave_index}, vr {vr}")
    return np.array(times[:got], dtype=np.int64), np.array(steps[:got]), np.array(values[:got], dtype=float)


def run_libcosim(
    ssp_path,
    step: float,
    stop_time: float,
    variables: Sequence[tuple[str, str]],
) -> pd.DataFrame:
    """Simulate ``ssp_path`` (.ssp zip, directory or .ssd) with libcosim.

    step, stop_time: seconds (libcosim works in integer nanoseconds).
    variables: (component, variable) pairs to record (Real, Integer, Boolean
    or String).  Real/Integer values are recorded for every communication
    point including t = start; Boolean/String values are sampled after every
    step (the t = start row is None for them).
    """
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    ssp_path = str(Path(ssp_path))
    step_ns = _to_nanos(step)
    if step_ns <= 0:
        raise ValueError("step must be at least 1 ns")
    execution = CosimExecution.from_ssp_file(ssp_path, step_ns)
    status = execution.status()
    start_ns = int(status.current_time)

    ts_observer = CosimObserver.create_time_series()
    lv_observer = CosimObserver.create_last_value()
    if not execution.add_observer(ts_observer) or not execution.add_observer(lv_observer):
        raise RuntimeError("could not add observers to the libcosim execution")

    # resolve names -> (slave index, value reference, type)
    slaves: dict[str, int] = {}
    for info in execution.slave_infos():
        slaves[info.name.decode()] = info.index
    resolved = []
    for comp, var in variables:
        if comp not in slaves:
            raise KeyError(f"no component {comp!r} in {ssp_path} (have {sorted(slaves)})")
        idx = slaves[comp]
        for vd in execution.slave_variables(idx):
            if vd.name.decode() == var:
                vtype = CosimVariableType(vd.type)
                resolved.append((comp, var, idx, int(vd.reference), vtype))
                break
        else:
            raise KeyError(f"component {comp!r} has no variable {var!r}")
        if vtype in (CosimVariableType.REAL, CosimVariableType.INTEGER):
            if not ts_observer.start_time_series(idx, int(vd.reference), vtype):
                raise RuntimeError(f"cannot observe {comp}.{var}")

    n_steps = int(round((float(stop_time) - start_ns / NANO) * NANO / step_ns))
    other = [r for r in resolved if r[4] in (CosimVariableType.BOOLEAN, CosimVariableType.STRING)]
    sampled: dict[str, list] = {f"{c}.{v}": [None] for c, v, *_ in other}
    for _ in range(n_steps):
        if not execution.step(1):
            from libcosimpy._internal import get_last_error_message

            raise RuntimeError(f"libcosim step failed at t={execution.status().current_time / NANO}: "
                               f"{get_last_error_message()}")
        for comp, var, idx, vr, vtype in other:
            if vtype == CosimVariableType.BOOLEAN:
                val = bool(lv_observer.last_boolean_values(idx, [vr])[0])
            else:
                val = lv_observer.last_string_values(idx, [vr])[0]
                val = val.decode() if isinstance(val, bytes) else val
            sampled[f"{comp}.{var}"].append(val)

    data: dict[str, object] = {}
    time_ns = start_ns + step_ns * np.arange(n_steps + 1, dtype=np.int64)
    data["time"] = time_ns / NANO
    for comp, var, idx, vr, vtype in resolved:
        key = f"{comp}.{var}"
        if key in sampled:
            data[key] = sampled[key]
            continue
        times, steps, values = _samples(ts_observer, idx, vr, n_steps + 1, vtype == CosimVariableType.INTEGER)
        if len(values) != n_steps + 1 or not np.array_equal(steps, np.arange(n_steps + 1)):
            raise RuntimeError(f"libcosim returned {len(values)} samples for {key}, expected {n_steps + 1}")
        if not np.array_equal(times, time_ns):
            raise RuntimeError(f"unexpected sample times for {key}")
        data[key] = values.astype(int) if vtype == CosimVariableType.INTEGER else values
    return pd.DataFrame(data)
