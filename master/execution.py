"""``Execution``: one co-simulation, stepped from Python. Everything that runs a system goes through it: the
``run`` function and the CLI, algorithms with rollback, interactive use, live streams.

Life cycle (as libcosim's ``execution``)::

    ex = Execution("scenario.ssp", step=0.1, output="out")   # nothing read yet
    ex.setup()              # parse the SSP, check it against the FMUs, resolve settings, choose observers
    ex.initialize()         # instantiate the FMUs, start values, initialization mode, first sample
    ex.step()               # one master step; returns the new time
    ex.simulate_until(5.0)  # steps until t >= 5.0 (or the run ends early)
    token = ex.save_state(); ...; ex.restore_state(token)     # rollback (FMUs that can get/set their state)
    ex.close()              # terminate and free the FMUs, finish observers, write run.json

``initialize`` calls ``setup`` and ``close`` may be called at any point (also after a failure): it keeps what
was recorded. ``with Execution(...) as ex:`` closes on leaving. Time is counted in whole steps
(t = start + n*h), so it does not drift.
"""
from __future__ import annotations

import os
import platform
import sys
import time as _time
from pathlib import Path

import numpy as np

from . import interrupts
from ._version import __version__
from .algorithms import get_algorithm
from .algorithms.finite import finite_check
from .drivers import driver_for
from .algorithms.ordering import algebraic_loops, gauss_seidel_order
from .errors import CosimError, ScenarioError
from .fmi.logsink import LogSink
from .fmi.ode_solvers import SolverChoice
from .live import check_options, open_streams, requested
from .log import warning
from .monitors import monitors_for
from .observers.base import ObserverContext
from .observers.pacing import Pacer
from .observers.recording import Recording, select_variables
from .plan import add_overrides, build_plan, value_error
from .plan.bare_fmu import bare_fmu_scenario, is_bare_fmu
from .results import (claim_output_folder, products, release_output_folder, settle_output_folder,
                      write_events_csv)
from .runtime import Runtime, SavedPoint
from .settings import resolve_settings
from .sinks import SINKS
from .ssp.archive import file_sha256, open_scenario, written_here
from .ssp.parser import read_ssd


#: a supervised run's simulation process leaves run.json's "platform" to its parent (master.supervise)
PLATFORM_FROM_PARENT = False


def platform_name() -> str | None:
    """``platform.platform()`` for run.json. It runs ``uname -p`` in a subprocess the first time in a process
    (2-17 ms): in a supervised run the parent asks it when it would otherwise wait for its child
    (``supervise.IDLE_CHORES``), and the child, whose start is the run's, does not (None, which the parent fills
    in)."""
    return None if PLATFORM_FROM_PARENT else platform.platform()


LONG_RUN_STEPS = 10**8        # beyond this a run is likely a typo (--step 1e-12, --stop-time 1e12): say so


class Options:
    """What a run can be told (the keyword arguments of ``run`` and ``Execution``): the names annotated below, each
    with its default. A plain class, not a dataclass: Python 3.11 compiles a dataclass's methods from source in
    every process (an ``exec`` each); with the run path's other records made plain this took 43 M instructions
    (~6 %) off a short run's start-up (bench/results/startup_2026-11-29b.md)."""
    stop_time: float | None = None
    start_time: float | None = None
    step: float | None = None
    algorithm: str | None = None
    output: str | os.PathLike | None = None           # a folder for the results; None: kept in memory only
                                                      # (the CLI defaults to results/<scenario name>)
    params: dict | None = None                        # "component.variable" -> value
    record: list[str] | None = None                   # shell patterns on "component.variable"
    record_interval: float | None = None
    log_level: str = "warning"
    seed: int | None = None                           # given to every component parameter named "seed"
    step_multiples: dict | None = None                # component -> k: it steps every k master steps
    inprocess: bool = True                            # pythonfmu FMUs called in process
    progress: bool = False                            # a progress bar on stderr
    write_csv: bool = True
    products: str = "all"                             # "summary": monitors write their summary files only
    allow_nonfinite: bool = False                     # let NaN and infinite values through (parameters, outputs)
    tolerance: float | None = None                    # given to every FMU (default: each FMU's own)
    solver: str = "cvode-bdf"                         # model exchange: "cvode-bdf", "cvode-adams", "euler"
    solver_step: float | None = None                  # euler's internal step (default: the communication step)
    lenient: bool = False                             # read slightly non-conforming modelDescriptions, warning
    implementation: dict | None = None                # component -> "ModelExchange" / "CoSimulation" / "any"
    output_prepared: bool = False                     # the caller made the folder for this run (a campaign puts the
                                                      # run's scenario there): use it as it is
    sinks: list[str] | None = None                    # output sinks by name (default: parquet, csv / memory)
    inputs: str | os.PathLike | None = None           # a CSV whose columns drive the one FMU's inputs (--input)
    native_loop: bool = True                          # step drivers (master/drivers/: native FMUs stepped in C)
    # the algorithms' settings (master.algorithm_options: types, defaults, docs); None: the SSD's, else the default
    extrapolation: int | None = None                  # coupled inputs: 0 held, 1 linear, 2 quadratic (jacobi, g-s)
    gs_interpolation: int | None = None               # gauss-seidel: known inputs interpolated (0 off, 1, 2)
    input_derivatives: int | None = None              # jacobi: the extrapolation polynomial as input derivatives
    coupling_tol: float | None = None                 # iterative: relative tolerance of the coupled values
    coupling_atol: float | None = None                # iterative: absolute tolerance (default: coupling_tol)
    coupling_max_iter: int | None = None              # iterative: iterations per step at most
    coupling_update: str | None = None                # iterative: "fixed-point", "aitken", "iqn-ils"
    coupling_interpolation: int | None = None         # iterative: 1 inputs interpolated over the step (trapezoidal)
    step_rtol: float | None = None                    # adaptive, ecco: relative tolerance of the step's error
    step_atol: float | None = None                    # adaptive, ecco: absolute tolerance (default: step_rtol)
    min_step: float | None = None                     # adaptive, ecco: smallest step (s)
    max_step: float | None = None                     # adaptive, ecco: largest step (s; at most the master step)
    initial_step: float | None = None                 # adaptive, ecco: first step (s)
    error_estimate: str | None = None                 # adaptive: "extrapolation" (default) or "doubling"
    threads: int | None = None                        # jacobi: doSteps of a step run concurrently (parallel.py)
    extrapolation_for: dict | None = None             # "component.output" -> its own order (jacobi, gauss-seidel)
    options_source: str = "command line"              # what run.json names as the source of the settings given
    mavlink: list[str] | None = None                  # live stream to these MAVLink addresses (master/live.py)
    mavlink_rate: float = 10.0                        # position and attitude messages per simulated second
    realtime: float | None = None                     # simulated s per wall s (None: as fast as it goes)
    reuse_structure: bool = False                     # a system this process has read before is read and planned
                                                      # again for its values only (campaign workers)

    def __init__(self, **options):
        names = Options.__annotations__
        for name, value in options.items():
            if name not in names:
                raise TypeError(f"Options.__init__() got an unexpected keyword argument {name!r}")
            setattr(self, name, value)

    def as_dict(self) -> dict:
        """Every option by name, given or default."""
        return {name: getattr(self, name) for name in Options.__annotations__}

    def __repr__(self):
        return f"Options({', '.join(f'{k}={v!r}' for k, v in self.as_dict().items())})"

    def __eq__(self, other):
        return self.as_dict() == other.as_dict() if other.__class__ is self.__class__ else NotImplemented


class Prepared:
    """A scenario resolved against its FMUs and the options, before anything is instantiated (shared by
    ``Execution.setup`` and ``inspect``)."""
    def __init__(self, shown_as: str, source, model, plan, user_params: dict):
        self.shown_as = shown_as
        self.source = source            # ssp.archive.ScenarioSource (close it when done)
        self.model = model              # ssp.model.SystemModel
        self.plan = plan                # plan.Plan
        self.user_params = user_params


def prepare(scenario, *, params: dict | None = None, seed: int | None = None, allow_nonfinite: bool = False,
            lenient: bool = False, implementation: dict | None = None, inputs=None,
            reuse_structure: bool = False) -> Prepared:
    """``reuse_structure``: the SSD's structure, and the plan's part that does not depend on parameter values,
    are taken from this process's earlier runs of the same structure and FMUs (``parser.structure_key``,
    ``plan._plan_key``) when there are any; the run's values are read and applied as always."""
    scenario = Path(scenario)
    shown_as = str(scenario)
    if is_bare_fmu(scenario):                         # run and inspected as an SSP of that one component
        scenario = bare_fmu_scenario(scenario)
    src = open_scenario(scenario, in_memory=True)     # an archive this process wrote: as the writer kept it
    try:
        model = read_ssd(src.ssd_path, src.root, shown_root=src.shown_root, reuse_structure=reuse_structure,
                         memory=src.memory)
        plan = build_plan(model, shown_as, allow_nonfinite=allow_nonfinite, lenient=lenient,
                          implementation=implementation, inputs=inputs)
        user_params = dict(_seed_params(plan.variables, seed) if seed is not None else {})
        user_params.update(params or {})
        add_overrides(plan, user_params, allow_nonfinite)
    except BaseException as exc:
        src.close()
        if scenario != Path(shown_as) and isinstance(exc, CosimError) and exc.file == shown_as:
            exc.line = None                 # a line of the SSD made for a bare FMU: no file the user has
        raise
    return Prepared(shown_as, src, model, plan, user_params)


def _seed_params(plan_vars, seed) -> dict:
    """A run seed is given to every component parameter named 'seed' (documented convention)."""
    out = {}
    for comp, vars_ in plan_vars.items():
        v = vars_.get("seed")
        if v is not None and v.causality == "parameter":
            why = value_error(v, int(seed))
            if why:
                raise ScenarioError(why, element="--seed")
            out[f"{comp}.seed"] = int(seed)
    return out


class ExecutionState:
    """A saved point of an execution (``save_state``): the steps done, every FMU's state and the buffers."""
    def __init__(self, n: int, point: SavedPoint):
        self.n, self.point = n, point


class Execution:
    def __init__(self, scenario, *, observers=(), manipulators=(), **options):
        self.wall0 = _time.perf_counter()
        if hasattr(scenario, "in_memory"):        # a system built in code (ssp.writer.SspBuilder): run from memory
            scenario = scenario.in_memory()
        self.scenario = Path(scenario)
        self.options = Options(**options)
        self.extra_observers = list(observers)
        self.manipulators = list(manipulators)
        self.out_dir = Path(self.options.output) if self.options.output is not None else None
        self.metadata: dict = {"scenario": str(self.scenario), "package_version": __version__,
                               "python": sys.version.split()[0], "platform": platform_name(),
                               "seed": self.options.seed, "outcome": "error"}
        self.events: list = []
        self.monitors: list = []
        self.observers: list = []
        self.recording: Recording | None = None
        self.live_observers: list = []   # live streams and pacing: finished with the monitors
        self.rt: Runtime | None = None
        self.log: LogSink | None = None
        self.prepared: Prepared | None = None
        self.n = 0                       # steps done
        self._driver, self._driver_asked = None, False    # the step driver (master/drivers/), asked once
        self.closed = False
        self.write_run_json = True       # a supervised child leaves run.json to its parent
        self.sinks_elsewhere = False     # ... and its recorded rows: it makes no sinks (nor imports pyarrow)
        self._set_up = self._initialized = self._claimed = False
        self._current: set | None = None  # names whose buffer slot is read every step (see "values by name")
        self._ports: dict = {}            # name -> (slave, port, buffer) of a variable read from its FMU

    # -- setup --------------------------------------------------------------------------------------------
    def setup(self) -> None:
        if self._set_up:
            return
        o, meta = self.options, self.metadata
        check_options(o)
        if self.out_dir is not None and self.write_run_json:    # a supervised child's parent claimed it
            if o.output_prepared:
                self.out_dir.mkdir(parents=True, exist_ok=True)
            else:
                claim_output_folder(self.out_dir)
            self._claimed = True
        if self.scenario.is_file() or written_here(self.scenario):     # written: maybe in memory only
            meta["scenario_sha256"] = file_sha256(self.scenario)
        self.prepared = p = prepare(self.scenario, params=o.params, seed=o.seed, allow_nonfinite=o.allow_nonfinite,
                                    lenient=o.lenient, implementation=o.implementation, inputs=o.inputs,
                                    reuse_structure=o.reuse_structure)
        model, plan, shown_as = p.model, p.plan, p.shown_as
        st = self.settings = resolve_settings(
            model, shown_as, start_time=o.start_time, stop_time=o.stop_time, step=o.step, algorithm=o.algorithm,
            record_interval=o.record_interval, step_multiples=o.step_multiples, fmus=plan.fmus, tolerance=o.tolerance)
        for name in st.step_multiples:
            if name not in plan.fmus:
                raise ScenarioError(f"step multiple given for unknown component {name!r}", file=shown_as,
                                    element="Settings")
        from .algorithm_options import resolve_algorithm_options
        st.sources.update(resolve_algorithm_options(o, model.settings.algorithm_options, o.options_source))
        from .algorithms.extrapolation import per_output_orders
        o.extrapolation_for, per_output_sources = per_output_orders(plan, o.extrapolation_for, o.options_source)
        if per_output_sources:
            st.sources["extrapolation_for"] = per_output_sources
        self.algorithm = get_algorithm(st.algorithm)
        self.algorithm.configure(o)
        self.solver = SolverChoice(o.solver, o.solver_step)
        self.solver.check()
        if st.steps > LONG_RUN_STEPS:
            warning(
                "%s steps of %g s from %g to %g s: this run may take very long (Ctrl-C keeps what it recorded)",
                f"{st.steps:,}", st.step, st.start, st.stop)
        meta.update({"algorithm": st.algorithm, "step_size": st.step, "step_size_source": st.step_source,
                     "start_time": st.start, "stop_time": st.stop, "steps": st.steps,
                     "record_interval": st.step * st.record_every, "step_multiples": st.step_multiples,
                     **({"last_step": st.last_step} if st.last_step is not None else {}),
                     "tolerance": st.tolerance, "settings_sources": st.sources,
                     "algorithm_options": {k: getattr(o, k) for k in _algorithm_option_names()},
                     "parameters_overridden": dict(p.user_params),
                     "fmus": {name: {"source": model.components[name].source, "sha256": f.sha256,
                                     "fmi_version": f.fmi_version,
                                     "kind": f.kind,
                                     "generation_tool": f.md.generationTool}
                              for name, f in plan.fmus.items()}})
        self.monitors = monitors_for(model, plan, shown_as)
        for m in self.monitors:
            m.products = o.products
        connected, seen = [], set()
        for ln in plan.links:
            if ln.src.qualified not in seen:
                seen.add(ln.src.qualified)
                connected.append(ln.src)
        record = o.record or model.settings.record or None
        recorded = select_variables(plan, record, connected)
        if record and not recorded:
            raise CosimError(f"no variable matches the record patterns {record}", element="--record")
        sink_names = o.sinks or ((["parquet"] + (["csv"] if o.write_csv else [])) if self.out_dir is not None
                                 else ["memory"])
        self.sinks = [] if self.sinks_elsewhere else [SINKS.get(name, element="sinks")() for name in sink_names]
        self.recording = Recording(recorded, self.sinks, self.out_dir, every=st.record_every, steps=st.steps)
        live = open_streams(o, self.monitors, plan, st) if requested(o) else None
        pacer = [Pacer(o.realtime)] if o.realtime is not None else []
        self.live_observers = [*(live.observers if live else []), *pacer]
        self.manipulators += live.manipulators if live else []
        # monitors first: they may take components out or end the run, which the recording's sample reflects;
        # live streams then see the step's events; pacing last, when the step's work is done
        self.observers = [*self.monitors, *(live.observers if live else []), *self.extra_observers,
                          self.recording, *pacer]
        self._set_up = True

    # -- initialization -----------------------------------------------------------------------------------
    def initialize(self) -> None:
        if self._initialized:
            return
        self.setup()
        o, st, plan, meta = self.options, self.settings, self.prepared.plan, self.metadata
        if self.out_dir is not None:
            try:
                log_file = open(self.out_dir / "fmu.log", "w", encoding="utf-8", buffering=1)
            except OSError as exc:
                raise CosimError(f"cannot create the output folder: {exc.strerror or exc}",
                                 file=str(self.out_dir), element="--output") from None
        else:
            log_file = None
        self.log = LogSink(o.log_level, file=log_file)
        loops, init_order = _graph_orders(plan, list(plan.fmus))
        meta["algebraic_loops"] = loops
        observed = _plan_vars(plan, [q for ob in self.observers for q in ob.required_variables()])
        sampled = _plan_vars(plan, [q for ob in self.observers for q in ob.sampled_variables()])
        # loggingOn stays on below 'none': some exporters (pythonfmu) drop even error messages without it
        # FMUs that keep files of their own (a SITL's eeprom and logs) put them into the run's output folder
        if self.out_dir is not None:
            os.environ["COSIM_MASTER_OUTPUT"] = str(self.out_dir.resolve())
        else:
            os.environ.pop("COSIM_MASTER_OUTPUT", None)
        self.rt = rt = Runtime(plan, observed, self.log, st.step_multiples, logging_on=(o.log_level != "none"),
                               inprocess=o.inprocess, sampled=sampled, solver=self.solver)
        rt.instantiate(st.start, st.stop, st.tolerance)
        rt.apply_start_values(st.start)
        loop_desc = "; ".join(" -> ".join(lp) for lp in loops) or "(none declared)"
        rt.initialize(st.start, init_order, bool(loops), loop_desc)
        meta["algorithm_info"] = self.algorithm.prepare(rt, plan, st.step)
        self.ctx = ObserverContext(rt, self.events)
        for ob in self.observers:
            ob.attach(self.ctx, st.start)
        for mp in self.manipulators:
            mp.attach(self.ctx, st.start)
        meta["last_time"] = st.start
        self._initialized = True

    # -- stepping -----------------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """The simulation time: the start time until the first step. Read before ``setup()``, it calls it (the
        start time is the SSD's, the FMUs' or the options', known once the settings are resolved)."""
        if not self._set_up:
            self.setup()
        st = self.settings
        if st.last_step is not None and self.n == st.steps:
            return st.stop            # after the shorter final step
        return st.start + self.n * st.step

    @property
    def stop_time(self) -> float:
        if not self._set_up:
            self.setup()
        return self.settings.stop

    @property
    def done(self) -> bool:
        """The stop time is reached or an observer ended the run."""
        if not self._set_up:
            self.setup()
        return self.n >= self.settings.steps or (self.rt is not None and self.rt.stop_reason is not None)

    def step(self) -> float:
        """One master step; returns the time reached."""
        if not self._initialized:
            self.initialize()
        if self.done:
            raise CosimError(f"the run has ended at t={self.time:g}; no further step", element="step")
        self._steps(self.n + 1)
        return self.time

    def simulate_until(self, t: float | None = None) -> float:
        """Step until the time reaches ``t`` (default: the stop time) or the run ends; returns the time."""
        if not self._initialized:
            self.initialize()
        st = self.settings
        target = st.steps if t is None else min(st.steps, _steps_to(st.start, st.step, t))
        if target > self.n and not self.done:
            self._steps(target)
        return self.time

    def _steps(self, target: int) -> None:
        """Steps ``self.n`` .. ``target``-1: THE step loop. Per step: the manipulators' ``before_step``, the
        algorithm's step (the shorter final step, if any, through ``step_sized``), the observers' ``after_step``,
        the test that every Real output is finite; the run ends early when an FMU or an observer asks
        (``rt.stop_reason``). A step driver (master/drivers/, asked once here) may run stretches of full-length
        steps instead, with the same effect bit for bit. ``n`` and ``last_time`` follow every step, also when one
        fails or is interrupted (an interrupt between a step and its observers leaves them at the last step the
        observers saw)."""
        st, meta, rt = self.settings, self.metadata, self.rt
        start, h = st.start, st.step
        step, step_sized = self.algorithm.step, self.algorithm.step_sized
        observers, manipulators = self.observers, self.manipulators
        check = None if self.options.allow_nonfinite else rt.nonfinite_error
        finite = None if check is None else finite_check(rt.out["Real"], rt.real_zeros)
        last_n = st.steps - 1 if st.last_step is not None else -1       # a shorter final step
        finals, partial = self._final_macro_steps()
        special = sorted(set(finals) | ({last_n} if last_n >= 0 else set()) | ({st.steps - 1} if partial else set()))
        bar = None
        if self.options.progress:
            from tqdm import tqdm
            bar = tqdm(total=target - self.n, unit="step", mininterval=0.5, leave=False)
        driver = self._step_driver() if target - self.n > 1 else None     # one step: not worth a driver's call
        n = self.n
        quiet = np.errstate(invalid="ignore", over="ignore")     # the finiteness check meets NaN on purpose
        quiet.__enter__()
        try:
            while n < target:
                if driver is not None and n not in special:
                    upto = next((m for m in special if m > n), target)
                    try:
                        driver.advance(n, min(target, upto), bar)
                    finally:
                        n = self.n
                    if rt.stop_reason is not None:
                        break
                    continue
                t = start + n * h          # integer step counting: no drift from accumulated additions
                for mp in manipulators:
                    mp.before_step(n, t)
                if n in finals:
                    step_sized(n, t, st.last_step if n == last_n else h, finals[n])
                    t1 = st.stop if n == last_n else start + (n + 1) * h
                elif n == last_n:
                    step_sized(n, t, st.last_step)
                    t1 = st.stop
                else:
                    step(n, t)
                    t1 = start + (n + 1) * h
                if partial and n == st.steps - 1:
                    for i in partial:          # a last macro step shorter than k master steps ends here
                        if rt.active[i]:
                            rt.publish(i)
                meta["last_time"] = t1
                for ob in observers:
                    ob.after_step(n, t, t1)
                n += 1
                self.n = n
                if check is not None and not finite():
                    raise check(t1)
                if rt.stop_reason is not None:
                    meta["ended_early"] = {"time": t1, "reason": rt.stop_reason}
                    break
                if bar is not None and (n & 255) == 0:
                    bar.update(256)
        finally:
            quiet.__exit__(None, None, None)
            rt.complete_call_counts()
            self.n = n
            meta["steps_done"] = n
            meta["last_time"] = self.time
            if bar is not None:
                bar.close()

    def _final_macro_steps(self) -> tuple[dict, list]:
        """({master step n0: {component index: length}}, [components whose last macro step is shorter than k master
        steps]): the last macro steps that settings.final_macro_steps ends at the stop time (the algorithm's
        ``step_sized`` gives them these lengths); the shorter ones publish their outputs at the last master step."""
        st, rt = self.settings, self.rt
        if not st.final_steps:
            return {}, []
        finals, partial = {}, []
        for name, (n0, length) in st.final_steps.items():
            i = rt.names.index(name)
            finals.setdefault(n0, {})[i] = length
            if n0 + rt.multiple[i] > st.steps:
                partial.append(i)
        return finals, partial

    def _step_driver(self):
        """The step driver of this execution (master/drivers/), chosen at its first call, or None."""
        if not self._driver_asked:
            self._driver_asked = True
            self._driver = driver_for(self)
        return self._driver

    # -- values by name ---------------------------------------------------------------------------------
    # What a script or a notebook reads and writes ("component.variable", as in results and --param). A value
    # comes from a buffer only where the master refreshes that slot after every step (a connection's source, a
    # variable an observer required at initialize, any read variable of a component on a step multiple, whose
    # values are staged); anything else (a variable only recorded, an unconnected input, a parameter, a local)
    # is read from its FMU through the Slave interface, so it is never a stale sample.

    def get(self, names):
        """The current value of ``"component.variable"`` (a list of names: a list of values), as a Python
        float, int, bool, str or bytes (an FMI 3 array: a list, row-major). Before ``initialize`` it is the
        value the run will start with: the one given by ``set``, ``params`` or the SSD, else the FMU's start
        value. A component on a step multiple is a whole multiple ahead inside: a variable the master does not
        transfer is read from the FMU as it is there (the end of its own step)."""
        if isinstance(names, str):
            return self._value(names)
        return [self._value(q) for q in names]

    def set(self, name: str, value) -> None:
        """Give ``"component.variable"`` a value. Before ``initialize``: its start value (a parameter, an input
        or another variable FMI lets a start value be set for; the same rules and checks as ``params``).
        After: an input no connection drives or a tunable parameter, applied at once and seen by the next step
        (FMI's rules between steps); anything else is a one-line CosimError naming the variable and why."""
        v = self._variable(name, "set")
        if self.closed:
            raise CosimError("the execution is closed; nothing can be set", element=f"set {name}")
        if not self._initialized:
            from .plan import add_overrides
            p = self.prepared
            before = list(p.plan.params)
            try:
                add_overrides(p.plan, {name: value}, self.options.allow_nonfinite)
            except ScenarioError as exc:
                p.plan.params[:] = before          # a refused value must not stay in the plan
                raise CosimError(f"cannot set it before initialize(): {exc.reason}", element=f"set {name}") from None
            p.user_params[name] = value
            self.metadata["parameters_overridden"] = dict(p.user_params)
            return
        from .observers.base import set_between_steps
        from .plan import parse_value
        set_between_steps(self.rt, v, value, element=f"set {name}")
        rt, parsed = self.rt, parse_value(v, value, name)
        for e, x in zip(self._elements(v), parsed if v.is_array else [parsed]):
            pos = rt.out_pos.get(e.qualified)         # a slot the master also reads shows the new value at once
            if pos is not None:
                rt.out[e.type][pos] = x

    def add_observer(self, observer) -> None:
        """Let ``observer`` (``master.observers.base.Observer``) see every step from now on. Before
        ``initialize`` it is attached with the others; after, it is attached at the current time, and the
        variables it requires must be ones the master reads every step (connected outputs, or those of an
        observer given before ``initialize``): others are an error naming them."""
        if self.closed:
            raise CosimError("the execution is closed", element="add_observer")
        if self._initialized:
            current = self._current_names()
            missing = [q for q in [*observer.required_variables(), *observer.sampled_variables()]
                       if not all(e.qualified in current for e in self._elements(self._variable(q, "observe")))]
            if missing:
                raise CosimError(f"{', '.join(missing)} {'is' if len(missing) == 1 else 'are'} not read every "
                                 "step; add this observer before initialize()", element="add_observer")
            observer.attach(self.ctx, self.time)
            if self._driver is not None:
                # a step driver was chosen for the observers there were: the reference loop runs the steps from here
                key = self._driver.name
                self.metadata[key] = {**self.metadata[key], "until": self.time,
                                      "reason": f"an observer was added at t={self.time:g}"}
                self._driver = None
        self.extra_observers.append(observer)
        if self._set_up:        # before the recording, as the observers given to the constructor
            at = self.observers.index(self.recording) if self.recording in self.observers else len(self.observers)
            self.observers.insert(at, observer)

    def _value(self, name: str):
        v = self._variable(name, "get")
        if not self._initialized:
            return self._start_value(v, name)
        if self.closed:
            raise CosimError("the execution is closed; its FMUs are gone (read the results instead)",
                             element=f"get {name}")
        rt = self.rt
        elements = self._elements(v)
        current = self._current_names()
        if all(e.qualified in current for e in elements):
            values = [rt.out[e.type][rt.out_pos[e.qualified]] for e in elements]
        else:
            values = self._read_fmu(v, elements, name)
        values = [_python(x, v.type) for x in values]
        return values if v.is_array else values[0]

    def _read_fmu(self, v, elements: list, name: str) -> list:
        """The variable's values (an array's elements) read from its FMU now."""
        from .fmi.slave import WARNING, new_buffer
        key = (v.component, v.array or v.name)
        bound = self._ports.get(key)
        if bound is None:
            rt = self.rt
            whole = self.prepared.plan.elements(v) if v.index is not None or v.is_array else [v]
            slave = rt.slaves[rt.index[v.component]]
            buf = new_buffer(v.type, len(whole))
            bound = self._ports[key] = (slave, slave.make_port(v.type, [e.vr for e in whole], buf), buf)
        slave, port, buf = bound
        st = slave.get_port(v.type, port)
        if st > WARNING:
            raise slave.fail(f"getting {name}", st, self.time)
        return list(buf) if v.index is None else [buf[v.index]]

    def _start_value(self, v, name: str):
        if not self._set_up:
            self.setup()
        given = None
        for pv, value, _ in self.prepared.plan.params:        # the last one given wins
            if pv.component == v.component and pv.name == (v.array or v.name):
                given = value
        if given is not None:
            return _python(given[v.index], v.type) if v.index is not None else (
                [_python(x, v.type) for x in given] if v.is_array else _python(given, v.type))
        if v.shape:
            return _python(v.start, v.type) if v.index is not None else [_python(x, v.type) for x in v.start]
        from .values import parse_text
        md_var = next((mv for mv in self.prepared.plan.fmus[v.component].md.modelVariables if mv.name == v.name),
                      None)
        start = getattr(md_var, "start", None)
        if start is None:
            raise CosimError(f"{name} has no start value; its value is known after initialize()", element=f"get {name}")
        return _python(parse_text(v.type, start) if isinstance(start, str) else start, v.type)

    def _variable(self, name: str, what: str):
        """The plan's variable called ``name``, or a one-line CosimError naming it and the closest names."""
        if not self._set_up:
            self.setup()
        plan = self.prepared.plan
        if not isinstance(name, str):
            raise CosimError(f"a variable is named by a string 'component.variable', not {name!r}", element=what)
        try:
            return plan.var(name)
        except ScenarioError:
            pass
        import difflib
        comps = list(plan.variables)
        owner = next((c for c in sorted(comps, key=len, reverse=True) if name.startswith(c + ".")), None)
        near = [owner] if owner else difflib.get_close_matches(name.split(".")[0], comps, n=3, cutoff=0.5)
        names = [f"{c}.{n}" for c in near for n in plan.variables[c]]
        close = difflib.get_close_matches(name, names, n=3, cutoff=0.6) or near
        why = (f"component {owner!r} has no variable {name[len(owner) + 1:]!r}" if owner
               else f"no component of {name!r} is in the system (components: {', '.join(comps)})")
        raise CosimError(why + (f"; close: {', '.join(close)}" if close else ""), element=f"{what} {name}")

    def _elements(self, v) -> list:
        return self.prepared.plan.elements(v) if v.is_array else [v]

    def _current_names(self) -> set:
        """The names whose buffer slot the master refreshes after every step: connection sources, the variables
        observers required at initialize, and whatever a component on a step multiple reads (with its step)."""
        if self._current is None:
            rt, plan = self.rt, self.prepared.plan
            current = set()
            for v in [ln.src for ln in plan.links] + _plan_vars(plan, [q for ob in self.observers
                                                                       for q in ob.required_variables()]):
                current.update(e.qualified for e in self._elements(v))
            staged = {name for name, k in zip(rt.names, rt.multiple) if k > 1}
            if staged:
                current.update(q for q in rt.out_pos if plan.split(q)[0] in staged)
            self._current = current
        return self._current

    # -- state (rollback) ---------------------------------------------------------------------------------
    def check_state_support(self) -> None:
        """One line naming every component that cannot save and restore its state, before a run needs it."""
        self.initialize()
        cannot = [s.name for s, on in zip(self.rt.slaves, self.rt.active) if on and not s.can_save_state]
        if cannot:
            which = f"components {', '.join(cannot)} cannot" if len(cannot) > 1 else f"component {cannot[0]} cannot"
            raise CosimError(f"{which} save and restore their state (canGetAndSetFMUstate is not true), which "
                             "rollback needs", file=self.prepared.shown_as,
                             element="rollback")

    def save_state(self) -> ExecutionState:
        """The state of every FMU and of the master's buffers at the current time. Observers are not saved:
        an algorithm rolls back within a step, before they see it."""
        self.initialize()
        return ExecutionState(self.n, SavedPoint(self.rt, self.time))

    def restore_state(self, state: ExecutionState) -> None:
        state.point.restore()
        self.n = state.n
        self.metadata["last_time"] = self.time

    def release_state(self, state: ExecutionState) -> None:
        state.point.release()

    # -- the end ------------------------------------------------------------------------------------------
    def close(self, outcome: str | None = None, error: CosimError | None = None) -> dict:
        """Terminate and free the FMUs, finish the observers, write run.json; returns the metadata. Safe to
        call at any point and more than once. Ctrl-C and SIGTERM wait until the files are whole."""
        if self.closed:
            return self.metadata
        with interrupts.deferred():
            return self._close(outcome, error)

    def _close(self, outcome: str | None, error: CosimError | None) -> dict:
        meta = self.metadata
        self.closed = True
        if outcome is not None:
            meta["outcome"] = outcome
        if error is not None:
            meta["error"] = str(error)
            if error.time is not None:
                meta["failed_at"] = error.time
        try:
            if self._initialized and self.recording is not None:
                try:
                    info = self.recording.finish(self.out_dir, meta["outcome"])
                    meta.update({"rows_recorded": info["rows"]}, **({"results_notes": info["notes"]}
                                                                  if "notes" in info else {}))
                except CosimError as exc:      # the last block could not be written (a full disk)
                    meta["rows_recorded"] = self.recording.rows_written
                    if meta["outcome"] == "completed" or "error" not in meta:
                        meta["outcome"], meta["error"] = "error", str(exc)
                    if self.recording.group.notes:
                        meta["results_notes"] = self.recording.group.notes
            if self.rt is not None:
                # before terminate: a model-exchange slave's solver goes with its instance
                meta["fmu_calls"] = {"do_step": dict(zip(self.rt.names, self.rt.do_step_calls)),
                                     "do_step_total": sum(self.rt.do_step_calls)}
                solvers = {s.name: s.stats() for s in self.rt.slaves if s is not None}
                if any(solvers.values()):
                    meta["solvers"] = {name: info for name, info in solvers.items() if info}
                self.rt.terminate()
                self.rt._at(0, -1)       # no component's call runs any more: a supervisor must not name the last
            for m in self.live_observers if not self._initialized else ():
                m.finish(self.out_dir, meta["outcome"])     # a stream opened before a failed start lets go
            if self._initialized:
                meta["algorithm_info"].update(self.algorithm.finish(self.out_dir))
            if self._initialized:
                for m in [*self.monitors, *self.extra_observers, *self.live_observers]:
                    try:
                        info = m.finish(self.out_dir, meta["outcome"])
                    except CosimError as exc:  # a monitor's report must not hide the run's own outcome
                        meta.setdefault("monitor_errors", []).append(str(exc))
                        continue
                    key = getattr(m, "annotation_type", "") or getattr(m, "name", "") or type(m).__name__
                    if m in self.monitors:
                        meta.setdefault("monitors", {})[key] = info
                    elif info:
                        meta.setdefault("observers", {})[key] = info
            if self.log is not None:
                meta["fmu_log_counts"] = {k: v for k, v in self.log.counts.items() if v}
                self.log.close()
        finally:
            if self.prepared is not None:
                self.prepared.source.close()
            meta["wall_time_s"] = _time.perf_counter() - self.wall0
            if self.write_run_json and self._claimed and self.out_dir.is_dir():
                write_run_files(self.out_dir, meta, self.events)
                if not self.options.output_prepared:
                    # the earlier run in the folder goes now that this one has rows, or comes back if it has none
                    settle_output_folder(self.out_dir, bool(meta.get("rows_recorded")))
                    release_output_folder(self.out_dir)
        return meta

    def memory_table(self):
        """The rows recorded so far by a run kept in memory (``output=None``), as a pyarrow Table: during a run
        (the rows of the block being filled included) and after it; None when the results go to a folder (read
        them with ``master.results.read_results``) or before ``initialize``."""
        from .sinks.memory import MemorySink
        for s in getattr(self, "sinks", ()):
            if isinstance(s, MemorySink) and hasattr(s, "blocks"):     # blocks: it was opened
                table = s.table()
                rec = self.recording
                if rec is not None and getattr(rec, "block", None) is not None and getattr(rec, "fill", 0):
                    import pyarrow as pa
                    from .observers.recording import block_table
                    pending = block_table(rec.schema, rec.block[: rec.fill], rec.str_rows)
                    table = pa.concat_tables([table, pending])
                return table
        return None

    def __enter__(self) -> "Execution":
        return self

    def __exit__(self, typ, exc, tb) -> None:
        if typ is None:
            self.close("completed" if self.done else "stopped")
        elif isinstance(exc, KeyboardInterrupt):
            self.close("interrupted", CosimError("interrupted by the user", time=self.metadata.get("last_time")))
        else:
            self.close("error", exc if isinstance(exc, CosimError) else None)


def _plan_vars(plan, names: list[str]) -> list:
    """``[plan.var(q) for q in names]``: a name whose last dot separates a component from one of its variables is
    the answer ``Plan.split`` finds first (it tries the longest component name first); the others go through it."""
    variables = plan.variables
    out = []
    for q in names:
        comp, _, name = q.rpartition(".")
        found = variables.get(comp)
        out.append(found[name] if found is not None and name in found else plan.var(q))
    return out


#: connection graph (see _graph_key) -> (algebraic loops, Gauss-Seidel order): a campaign worker initializes the
#: same few systems run after run, and working both out again cost ~0.5 ms a run
_GRAPH_ORDERS: dict[tuple, tuple] = {}
_MAX_GRAPH_ORDERS = 64


def _graph_key(plan, names: list[str]) -> tuple:
    """All that ``algebraic_loops`` and ``gauss_seidel_order`` read of a plan: the components' order, each link's
    ends and the declared dependencies of its source output (None: depends on every input)."""
    feed = plan.feedthrough
    ends = []
    for ln in plan.links:
        s, d = ln.src, ln.dst
        deps = feed.get(s.component, {}).get(s.name, None)
        ends.append((s.component, s.name, d.component, d.name, None if deps is None else frozenset(deps)))
    return tuple(names), tuple(ends)


def _graph_orders(plan, names: list[str]) -> tuple[list[list[str]], list[int]]:
    """``algebraic_loops(plan)`` and ``gauss_seidel_order(plan, names).order``, worked out once per graph; the run
    gets lists of its own (the loops go into run.json)."""
    key = _graph_key(plan, names)
    known = _GRAPH_ORDERS.get(key)
    if known is None:
        if len(_GRAPH_ORDERS) >= _MAX_GRAPH_ORDERS:
            _GRAPH_ORDERS.clear()
        known = _GRAPH_ORDERS[key] = (algebraic_loops(plan), gauss_seidel_order(plan, names).order)
    loops, order = known
    return [list(lp) for lp in loops], list(order)


def _python(x, typ: str):
    """A buffer's value as the Python value of its base type."""
    if typ == "Real":
        return float(x)
    if typ == "Boolean":
        return bool(x)
    if typ in ("String", "Binary"):
        return x
    return int(x)


def _algorithm_option_names():
    from .algorithm_options import ALGORITHM_OPTIONS
    return list(ALGORITHM_OPTIONS)


def _steps_to(start: float, h: float, t: float) -> int:
    """The number of steps whose end reaches ``t`` (a time within 1e-9 steps of a grid point counts as on it)."""
    import math
    k = (t - start) / h
    return max(0, int(math.ceil(k - 1e-9)))


def write_run_files(out_dir: Path, meta: dict, events: list) -> None:
    """events.csv (when there are events) and run.json, each replaced atomically."""
    if events:
        def write_events(tmp: Path) -> None:
            if not write_events_csv(events, tmp):       # values the pandas twin does not cover
                import pandas as pd
                pd.DataFrame(events).to_csv(tmp, index=False)
        _replace(out_dir / "events.csv", write_events)
    import json     # here: a supervised run's simulation process, whose start is the run's, writes no run.json
    meta["products"] = products(out_dir)
    _replace(out_dir / "run.json", lambda tmp: tmp.write_text(json.dumps(meta, indent=2, default=_json_default)))


def _replace(target: Path, write) -> None:
    """``write(tmp)`` then tmp renamed to ``target``; a write that fails (a full disk) leaves the old ``target``
    and no half-written ``.tmp`` beside it."""
    tmp = target.with_name(target.name + ".tmp")
    try:
        write(tmp)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, target)


def _json_default(o):
    try:
        import numpy as np
        if isinstance(o, np.generic):
            return o.item()
    except ImportError:
        pass
    return str(o)
