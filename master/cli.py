"""The ``cosim-master`` command."""
from __future__ import annotations

import argparse
import math
import sys

from ._version import __version__
from .errors import CosimError


def _kv(items, what):
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise CosimError(f"expected NAME=VALUE, got {item!r}", element=what)
        out[key.strip()] = value
    return out


class _AsWritten(float):
    """A number that is not finite, shown as the user wrote it (1e400, not inf) in the one-line error that
    refuses it; finite numbers stay plain floats."""
    def __new__(cls, text: str):
        self = super().__new__(cls, text)
        self.text = text
        return self

    def __repr__(self):
        return self.text

    __str__ = __repr__


def _number(text: str) -> float:
    value = float(text)     # a ValueError is argparse's "invalid _number value"
    return value if math.isfinite(value) else _AsWritten(text)


_number.__name__ = "number"


IMPLEMENTATIONS = {"me": "ModelExchange", "cs": "CoSimulation", "any": "any"}


def _implementations(items) -> dict | None:
    out = {}
    for comp, kind in _kv(items, "--implementation").items():
        if kind.strip().lower() not in IMPLEMENTATIONS:
            raise CosimError(f"{comp}: expected me, cs or any, got {kind!r}", element="--implementation")
        out[comp] = IMPLEMENTATIONS[kind.strip().lower()]
    return out or None


def _orders(items) -> dict | None:
    out = {}
    for name, k in _kv(items, "--extrapolate").items():
        try:
            out[name] = int(k)
        except ValueError:
            raise CosimError(f"the order must be 0, 1 or 2, got {k!r}", element=f"--extrapolate {name}") from None
    return out or None


def _algorithm_option_flags(p) -> None:
    """One flag per algorithm setting (master.algorithm_options); unset flags leave the SSD's or the default."""
    from .algorithm_options import ALGORITHM_OPTIONS
    for opt in ALGORITHM_OPTIONS.values():
        default = "" if opt.default is None else f" (default: {opt.default})"
        # the values are checked by the option's own parser (the same for the SSD and a campaign), so a choice
        # is listed in the help rather than given to argparse
        one_of = f"; one of {', '.join(map(str, opt.choices))}" if opt.choices else ""
        p.add_argument(opt.flag, dest=opt.name, default=None, metavar=opt.name.split("_")[-1].upper(),
                       help=f"{opt.help}{one_of}{default}")


def _algorithm_option_values(args) -> dict:
    from .algorithm_options import ALGORITHM_OPTIONS
    return {name: getattr(args, name) for name in ALGORITHM_OPTIONS if getattr(args, name, None) is not None}


class _OneLineParser(argparse.ArgumentParser):
    """A usage error as one line, like every other error (the usage itself is a --help away); exit code 2."""
    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class _CommandParser(_OneLineParser):
    """One command's parser."""


class _NotBuilt:
    """Stands for the parser of a command not given (``_parser``): its arguments are taken as read."""
    def add_argument(self, *args, **kwargs):
        return None


def _command_in(argv) -> str | None:
    """The command ``argv`` names (its first word not an option: the program's own options take no value), or
    None: then every command is built, so that a misspelt one is told the choices as before."""
    words = [a for a in (sys.argv[1:] if argv is None else argv) if not a.startswith("-")]
    return words[0] if words and words[0] in COMMANDS else None


def _built_for(argv) -> str | None:
    """The command whose parser alone ``argv`` needs (``_parser``): the one it names, unless the program's own help
    comes before it (``cosim-master -h run`` lists every command)."""
    command = _command_in(argv)
    args = sys.argv[1:] if argv is None else argv
    if command is not None and {"-h", "--help"} & set(args[:args.index(command)]):
        return None
    return command


#: every command of the program, in the order --help lists them
COMMANDS = ("run", "inspect", "campaign", "report", "study", "stability", "build-scenario", "replay")


def _parser(command: str | None = None) -> argparse.ArgumentParser:
    """The program's parser; ``command``: only that command is built, the others are not there (None: all). The
    others' parsers and ~100 arguments were ~5 M instructions (~1 %) of a short run's start-up; a command given
    parses, helps and refuses as with every command built, and the program's own help, which lists them all,
    builds them all (``_built_for``)."""
    # imported here, not with the module: they import NumPy, and entry() must be able to take a Ctrl-C first
    from .algorithms import ALGORITHMS
    from .fmi.ode_solvers import SOLVERS
    p = _OneLineParser(prog="cosim-master", description="FMI/SSP fixed-step co-simulation master")
    p.add_argument("--version", action="version", version=f"cosim-master {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_CommandParser)

    def add(name: str, **kwargs) -> _CommandParser:
        return sub.add_parser(name, **kwargs) if command in (None, name) else _NotBuilt()

    r = add("run", help="run a scenario (.ssp, SSP folder, .ssd or a bare .fmu)",
                       description="Run a scenario from its start to its stop time and write its results (Parquet, "
                                   "CSV, run.json, events and monitor files) into one folder. Settings not given "
                                   "here come from the SSD's settings annotation, then from the FMUs' default "
                                   "experiments.")
    r.add_argument("scenario", help="an .ssp archive, an unpacked SSP folder, a SystemStructure.ssd file, or a bare .fmu "
                   "(run as an SSP of that one component, named as the file)")
    r.add_argument("--stop-time", type=_number, metavar="SECONDS", help="simulated time to stop at, in seconds")
    r.add_argument("--start-time", type=_number, metavar="SECONDS", help="simulated start time, in seconds")
    r.add_argument("--step", type=_number, metavar="SECONDS", help="master (communication) step size, in seconds")
    # the registry as choices, with a metavar: a name given is looked up alone, the list only made for --help
    r.add_argument("--algorithm", choices=ALGORITHMS, metavar="NAME",
                   help="co-simulation algorithm: %(choices)s (default: jacobi)")
    _algorithm_option_flags(r)
    r.add_argument("--extrapolate", action="append", metavar="COMPONENT.VARIABLE=K", default=[],
                   help="extrapolation order K (0, 1, 2) of one coupled output, overriding --extrapolation for it "
                        "(jacobi, gauss-seidel); repeatable")
    r.add_argument("--tolerance", type=_number, metavar="REL",
                   help="relative tolerance given to every FMU (default: each FMU's own default experiment)")
    r.add_argument("--output", "-o", default=None, metavar="DIR",
                   help="result folder (default: results/<scenario name>); an earlier run's folder is replaced, "
                        "a non-empty folder of other files is refused")
    r.add_argument("--param", action="append", metavar="COMPONENT.VARIABLE=VALUE", default=[],
                   help="set a parameter or start value (in the variable's own unit); repeatable")
    r.add_argument("--input", metavar="FILE.csv",
                   help="drive the inputs of a one-FMU scenario from a CSV file: a 'time' column, then one column "
                        "per input, named as the input (the FMI cross-check _in.csv format)")
    r.add_argument("--record", action="append", metavar="PATTERN", default=[],
                   help="record the variables whose 'component.variable' matches this shell pattern "
                        "(default: every connected output); repeatable")
    r.add_argument("--record-interval", type=_number, metavar="SECONDS",
                   help="time between recorded rows, in seconds: a whole multiple of the step (default: every step)")
    r.add_argument("--step-multiple", action="append", metavar="COMPONENT=K", default=[],
                   help="the component steps every K master steps (K a positive integer); repeatable")
    r.add_argument("--seed", type=int, help="given to every component parameter named 'seed'")
    r.add_argument("--log-level", choices=["debug", "info", "warning", "error", "none"], default="warning",
                   help="FMU messages shown from this level up (all go to fmu.log; default: warning)")
    r.add_argument("--no-csv", action="store_true", help="write results.parquet only, no results.csv")
    r.add_argument("--solver", choices=SOLVERS, default="cvode-bdf",
                   help="integrator of model-exchange components (default: cvode-bdf; euler: explicit fixed step)")
    r.add_argument("--solver-step", type=_number, metavar="S",
                   help="euler's internal step (default: each communication step whole)")
    r.add_argument("--no-inprocess", action="store_true",
                   help="call pythonfmu FMUs through their binary instead of loading their slave class in process")
    r.add_argument("--no-native-loop", action="store_true",
                   help="step native FMUs from Python instead of the loop in C (same results, slower)")
    r.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="show a progress bar on stderr (default: when stderr is a terminal, so that nothing floods "
                        "a log)")
    r.add_argument("--timeout", type=_number, metavar="SECONDS",
                   help="wall-clock limit of the run, in seconds; the simulation is stopped and its results kept")
    r.add_argument("--implementation", action="append", metavar="COMPONENT=me|cs", default=[],
                   help="run the component's FMU as model exchange or co-simulation (default: the SSD's "
                        "implementation attribute, else co-simulation when the FMU offers both); repeatable")
    r.add_argument("--lenient", action="store_true",
                   help="accept slightly non-conforming modelDescription.xml files, and --input columns that name no "
                        "input (ignored), saying what was tolerated")
    r.add_argument("--allow-nonfinite", action="store_true",
                   help="let NaN and infinite values through (default: a parameter or output that is not finite "
                        "ends the run with an error at the step it appears)")
    r.add_argument("--no-supervise", action="store_true",
                   help="simulate in this process (default: a child process, so that a crashing or hanging FMU "
                        "cannot take the results with it)")
    r.add_argument("--mavlink", action="append", metavar="URL", default=[],
                   help="stream the run live to a ground station at this pymavlink address (udpout:HOST:PORT, "
                        "udpin:HOST:PORT, tcpin:HOST:PORT, tcp:HOST:PORT) and take its commands; repeatable "
                        "(docs/ground_station.md)")
    r.add_argument("--mavlink-rate", type=_number, default=10.0, metavar="HZ",
                   help="position and attitude messages per vehicle and simulated second (default: 10)")
    r.add_argument("--realtime", type=_number, metavar="FACTOR",
                   help="pace the run to the wall clock: FACTOR simulated seconds per second (1: real time, "
                        "10: ten times faster); results are the same as unpaced")
    r.add_argument("--debug", action="store_true", help="show Python tracebacks")

    i = add("inspect", help="describe a scenario and the settings a run would use")
    i.add_argument("scenario", help="an .ssp archive, an unpacked SSP folder, a SystemStructure.ssd file, or a bare "
                                    ".fmu (shown as an SSP of that one component)")
    i.add_argument("--json", action="store_true", help="print the description as JSON instead of text")
    i.add_argument("--step", type=_number, metavar="SECONDS",
                   help="show the settings a run with this master step size would use")
    i.add_argument("--stop-time", type=_number, metavar="SECONDS",
                   help="show the settings a run to this simulated time would use")
    i.add_argument("--algorithm", choices=ALGORITHMS, metavar="NAME",
                   help="show the settings and loop treatment of this algorithm: %(choices)s (default: the "
                        "scenario's)")
    i.add_argument("--debug", action="store_true", help="show Python tracebacks")

    c = add("campaign", help="run a grid or list of scenario runs (resumable)",
                       description="Run the campaign's missing runs into its folder and rebuild its table. Exit "
                                   "status: 0 when every run has a record and none failed, 1 otherwise, 130 after "
                                   "Ctrl-C and 143 after SIGTERM (complete records kept; the same command "
                                   "resumes).")
    c.add_argument("campaign_yaml", help="the campaign file: its scenarios, grid or list of runs, run settings and "
                                         "repetitions (docs/campaigns.md)")
    c.add_argument("--output", "-o", default=None, metavar="DIR",
                   help="campaign folder (default: results/<campaign name>); the same command again resumes the "
                        "campaign there")
    c.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes (default: every core)")
    c.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address of a Dask distributed scheduler (tcp://host:8786) to run on instead of local workers")
    c.add_argument("--retry-failed", action="store_true", help="run the runs recorded as failed again")
    c.add_argument("--max-runs", type=int, default=None, metavar="N",
                   help="run at most N of the missing runs now (the rest stay for the next invocation)")
    c.add_argument("--no-progress", action="store_true",
                   help="no progress bar (default: one when stderr is a terminal)")
    c.add_argument("--debug", action="store_true", help="show Python tracebacks")

    rp = add("report", help="figures, tables and a markdown report of a finished campaign "
                                       "(as the scenario kind recorded in its campaign.json writes it)")
    rp.add_argument("campaign_dir", help="the folder of a campaign run by `cosim-master campaign` (holding its "
                                         "campaign.json); report.md and the figures are written into it")
    rp.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                    help="show a progress bar on stderr (default: when stderr is a terminal, so that nothing floods "
                         "a log)")
    rp.add_argument("--debug", action="store_true", help="show Python tracebacks")

    st = add("study", help="a grid of algorithms, extrapolation orders and steps, measured against a "
                                      "reference: study.csv (errors, observed order, FMU calls) and figures",
                        description="Run every combination of --algorithm, --extrapolation and --step on one "
                                    "scenario (as a resumable campaign), compare each run with the reference at its "
                                    "recorded times and write study.csv and PNG figures into --output "
                                    "(docs/coupling.md).")
    st.add_argument("scenario", help="the scenario studied: an .ssp archive, an unpacked SSP folder or a "
                                     "SystemStructure.ssd file")
    # checked by the study (its own one-line error), listed by `run --help`: listing them here imported them all
    st.add_argument("--algorithm", nargs="+", required=True, metavar="A",
                    help="the algorithms compared, one or more of the names `cosim-master run --help` lists for "
                         "--algorithm")
    st.add_argument("--extrapolation", nargs="+", type=int, default=[0], metavar="K",
                    help="the input extrapolation orders compared, of 0, 1, 2 (default: 0)")
    st.add_argument("--step", nargs="+", type=_number, required=True, metavar="H",
                    help="the master step sizes, in seconds (at least two for an observed order)")
    st.add_argument("--reference", required=True, metavar="REF",
                    help="analytic:MODULE:FUNCTION (MODULE a .py file or module name; FUNCTION(t) returns the "
                         "signals by name), fine:H (the scenario at steps H and H/2 with second-order iterative "
                         "coupling, its error estimated from the two) or a results file (.parquet, .csv)")
    from .algorithm_options import ALGORITHM_OPTIONS
    for opt in ALGORITHM_OPTIONS.values():      # every algorithm setting is an axis (for the algorithms reading it)
        if opt.name != "extrapolation":
            st.add_argument(opt.flag, nargs="+", dest=f"sweep_{opt.name}", metavar="V",
                            help=f"swept: {opt.help}" + (f" (for {', '.join(opt.applies_to)})" if opt.applies_to else ""))
    st.add_argument("--record", nargs="+", metavar="PATTERN", help="the signals to compare (default: every "
                                                                   "connected output the reference knows)")
    st.add_argument("--stop-time", type=_number, metavar="SECONDS",
                    help="simulated time to stop every run at (default: the scenario's)")
    st.add_argument("--output", "-o", required=True, metavar="DIR",
                    help="study folder: the runs, study.csv and the figures; a study run there before resumes")
    st.add_argument("--workers", type=int, default=None, metavar="N",
                    help="local worker processes (default: every core)")
    st.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="address of a Dask distributed scheduler (tcp://host:8786) to run on instead of local workers")
    st.add_argument("--no-progress", action="store_true",
                    help="no progress bar (default: one when stderr is a terminal)")
    st.add_argument("--debug", action="store_true", help="show Python tracebacks")

    sb = add("stability", help="the spectral radius of the coupled step map per scheme and step, "
                                          "identified from the FMUs: stability.csv and stability.png",
                        description="Identify the coupled step map of every scheme (--algorithm with each "
                                    "--extrapolation and --gs-interpolation it takes) at every --step from the FMUs "
                                    "and write its spectral radius into --output (docs/coupling.md).")
    sb.add_argument("scenario", help="the scenario: an .ssp archive, an unpacked SSP folder or a .ssd file")
    sb.add_argument("--algorithm", nargs="+", required=True, metavar="A",
                    help="jacobi, gauss-seidel and/or iterative")
    sb.add_argument("--extrapolation", nargs="+", type=int, default=[0], metavar="K",
                    help="input extrapolation orders (jacobi, gauss-seidel), of 0, 1, 2 (default: 0)")
    sb.add_argument("--gs-interpolation", nargs="+", type=int, default=[0], metavar="M",
                    help="gauss-seidel interpolation orders, of 0, 1, 2 (default: 0)")
    sb.add_argument("--step", nargs="+", type=_number, required=True, metavar="H", help="master step sizes (s)")
    sb.add_argument("--param", action="append", metavar="COMPONENT.VARIABLE=VALUE", default=[],
                    help="set a parameter for every point; repeatable")
    sb.add_argument("--vary", metavar="COMPONENT.VARIABLE=V1,V2,...",
                    help="sweep one parameter too (the figure then plots against it)")
    sb.add_argument("--output", "-o", required=True, metavar="DIR", help="folder for stability.csv and .png")
    sb.add_argument("--debug", action="store_true", help="show Python tracebacks")

    b = add("build-scenario", help="write the SSP of a scenario described in another format, e.g. a "
                                              "UAV study YAML (the scenario kind that claims the file builds it)")
    b.add_argument("scenario_yaml", help="the scenario description, e.g. a UAV study YAML "
                                         "(ssp/scenarios/paper_area.yaml)")
    b.add_argument("-o", "--output", required=True, metavar="FILE.ssp",
                   help="the SSP to write: an .ssp archive, or a folder for an unpacked SSP")
    b.add_argument("--debug", action="store_true", help="show Python tracebacks")

    rv = add("replay", help="write replay.html, the run seen again in a browser, into a finished run's "
                                       "folder (as the scenario kind that claims the run writes it, e.g. a UAV run)")
    rv.add_argument("run_dir", help="the folder of a finished run (holding its run.json), e.g. results/paper_zones_4uav_B")
    rv.add_argument("--scenario", default=None, metavar="FILE.ssp",
                    help="the scenario the run flew, when the path in run.json no longer finds it")
    rv.add_argument("--debug", action="store_true", help="show Python tracebacks")
    return p


def _show_warnings():
    """The engine's warnings (logger 'cosim_master') as 'cosim-master: warning: ...' lines on stderr, until the
    returned function puts the logger back: ``main`` may be called again in one process (a notebook, a test), and
    a handler left behind would write to the stderr of an earlier call and keep the warnings from the caller's
    own logging. The line format is installed when the logger is first used (``master.log``): a run that warns
    of nothing does not import logging."""
    from . import log
    restores = []

    def install(logger):
        restores.append(_warning_lines(logger))
    log.when_first_used(install)

    def restore():
        log.forget(install)
        for undo in restores:
            undo()
    return restore


def _warning_lines(log):
    """Installs the warning lines on the logger ``log``; returns what puts it back."""
    import logging
    if log.handlers:        # the caller set up the engine's logging: it stays theirs
        return lambda: None
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("cosim-master: %(levelname)s: %(message)s"))
    level, propagate = log.level, log.propagate
    log.addHandler(handler)
    log.setLevel(logging.WARNING)
    log.propagate = False

    def restore():
        log.removeHandler(handler)
        log.setLevel(level)
        log.propagate = propagate
    return restore


#: the variables with which a user chooses OpenBLAS's threads; with none set, this process's NumPy gets one
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")


def _numpy_single_threaded() -> None:
    """NumPy imported with OpenBLAS on one thread, unless the user chose otherwise. OpenBLAS starts a thread per
    core when it is loaded, and they spin for a while: on a busy two-core machine that was ~20 ms of CPU and
    ~0.1 s of wall time of a short run, in both processes of a supervised one (the supervisor imports NumPy
    before it forks). A run does no linear algebra where a second BLAS thread would pay (small matrices at
    most); dask's nanny makes the same choice for its workers. Only this process: the variable is gone again
    before anything starts another one (an FMU's own process, a campaign's workers), which chooses for itself."""
    import os
    if any(name in os.environ for name in BLAS_THREAD_VARIABLES) or "numpy" in sys.modules:
        return
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    try:
        import numpy  # noqa: F401 - OpenBLAS reads the variable when it is loaded, with NumPy
    finally:
        del os.environ["OPENBLAS_NUM_THREADS"]


def entry() -> int:
    """The program (console script, ``python -m master.cli``): ``main``, then late interrupts ignored."""
    import signal

    from .interrupts import quiet_until_started
    quiet_until_started()       # a Ctrl-C while the modules are imported: one line, exit 130
    if hasattr(signal, "SIGXFSZ"):
        # a file size limit (ulimit -f) is a write that fails, as a full disk is, not a death that loses the run
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    import gc
    # what the start-up imports create lives as long as the process: the cyclic collector, which went over it again
    # and again while it grew (~20 ms of a short run), is off until the command's modules are in (_import_command)
    gc.disable()
    _numpy_single_threaded()
    global _only_supervised
    _only_supervised = False        # (a main() called before in this process, a test's, set it for itself)
    try:
        code = main(own_process=True)
    finally:
        # the exit code is decided: a Ctrl-C while the interpreter shuts down would turn it into a death by signal
        import signal
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)       # and so would a SIGTERM (its handler is reset then)
    if _only_supervised:
        _exit_now(code)
    return code


#: this process only supervised a run (master.supervise): it ran no FMU and no user code, and what it wrote is
#: closed, so nothing is left that the interpreter's teardown would finish
_only_supervised = False


def _exit_now(code: int) -> None:
    """Ends the process without the interpreter's teardown, which takes every object of NumPy, pyarrow and the
    engine apart one by one (~20 ms, a tenth of a short run)."""
    import os
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):   # a closed pipe: as the teardown would, say nothing
            pass
    os._exit(code)


def main(argv=None, *, own_process: bool = False) -> int:
    """The command line ``argv``; ``own_process``: this process is the command's alone (``entry``), see
    ``_import_command``."""
    args = _parser(_built_for(argv)).parse_args(argv)
    restore_logging = _show_warnings()
    try:
        _import_command(args.command, own_process)
        return _dispatch(args)
    except CosimError as exc:
        if getattr(args, "debug", False):
            raise
        print(f"cosim-master: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        from .errors import Terminated
        term = isinstance(exc, Terminated)
        print(f"cosim-master: {'stopped by SIGTERM' if term else 'interrupted'}"
              + ("; the same command resumes the campaign" if args.command == "campaign" else ""), file=sys.stderr)
        return 143 if term else 130
    finally:
        restore_logging()


#: the modules a command imports before it starts work: a Ctrl-C while they load exits at once (entry())
COMMAND_MODULES = {"run": ("master.runner", "master.supervise"), "inspect": ("master.inspect_scenario",),
                   "campaign": ("master.campaign.runner",), "study": ("master.study",),
                   "report": ("master.campaign.report",), "build-scenario": ("master.scenario_kinds",)}


def _import_command(command: str, own_process: bool = False) -> None:
    """Imports the command's modules, then lets a Ctrl-C raise KeyboardInterrupt, which the command handles. In a
    process of its own the command starts with everything imported so far frozen (``gc.freeze``: never collected,
    and a forked child, the supervised run's simulation, does not copy the pages a collection would write) and the
    collector on again."""
    import importlib

    from .interrupts import started
    for name in COMMAND_MODULES.get(command, ()):
        importlib.import_module(name)
    if own_process:
        import gc
        gc.freeze()
        gc.enable()
        if command == "run":        # and the supervisor's imports after the fork too
            sys.modules["master.supervise"].OWN_PROCESS = True
    started()


def _refuse_other_kinds(scenario) -> None:
    """A scenario of another kind (a study's YAML) is built into an SSP first: say how, instead of the SSP reader's
    "not a readable SSP archive".  Asked here, at the top, because only the command knows the scenario kinds: the
    SSP reader below knows SSPs and nothing else."""
    import zipfile
    from pathlib import Path

    path = Path(scenario)
    if not path.is_file() or path.suffix.lower() == ".ssd" or zipfile.is_zipfile(path):
        return
    from .scenario_kinds import kind_claiming
    try:
        kind = kind_claiming(path)
    except Exception:   # noqa: BLE001 - only a better message is at stake here
        return
    if kind is not None and kind.name != "ssp":
        from .errors import ScenarioError
        raise ScenarioError(f"this is a {kind.label} scenario, not an SSP: build one with `cosim-master build-scenario "
                            f"{path} -o scenario.ssp` and run that", file=path)


def _refuse_file_as_folder(output: str) -> None:
    """An output folder whose path is a file (or runs through one) says so, instead of the OS's "File exists"."""
    from pathlib import Path
    path = Path(output)
    for p in (path, *path.parents):
        if p.exists() or p.is_symlink():
            if not p.is_dir():
                what = "is a file" if p == path else f"is inside {p}, which is a file"
                raise CosimError(f"the output folder {what}, not a folder: give another -o DIR", file=output,
                                 element="--output")
            return


def _stop_on_sigterm() -> None:
    """SIGTERM (timeout, systemd, kill) raises Terminated, a KeyboardInterrupt, in this process only: spawned
    workers start with their own handlers."""
    import signal

    from .errors import Terminated

    def terminated(signum, frame):
        raise Terminated()
    signal.signal(signal.SIGTERM, terminated)


def _progress(asked: bool | None) -> bool:
    """A bar when asked, else when a person watches: stderr a terminal (a pipe or a log file gets none)."""
    if asked is not None:
        return asked
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):      # replaced or closed stderr
        return False


def _dispatch(args) -> int:
    if args.command in ("run", "inspect"):
        _refuse_other_kinds(args.scenario)
    if args.command == "run":
        from pathlib import Path

        from .runner import run
        output = args.output or str(Path("results") / Path(args.scenario).stem)
        multiples = {}
        for k, v in _kv(args.step_multiple, "--step-multiple").items():
            try:
                multiples[k] = int(v)
            except ValueError:
                raise CosimError(f"step multiple of {k} must be an integer, got {v!r}", element="--step-multiple") from None
        options = dict(stop_time=args.stop_time, start_time=args.start_time, step=args.step,
                       algorithm=args.algorithm, output=output, params=_kv(args.param, "--param"),
                       record=args.record or None, record_interval=args.record_interval, log_level=args.log_level,
                       seed=args.seed, step_multiples=multiples, progress=_progress(args.progress), write_csv=not args.no_csv,
                       inprocess=not args.no_inprocess, allow_nonfinite=args.allow_nonfinite,
                       native_loop=not args.no_native_loop,
                       tolerance=args.tolerance, solver=args.solver, solver_step=args.solver_step,
                       lenient=args.lenient,
                       implementation=_implementations(args.implementation), inputs=args.input,
                       mavlink=args.mavlink or None, mavlink_rate=args.mavlink_rate, realtime=args.realtime,
                       extrapolation_for=_orders(args.extrapolate), **_algorithm_option_values(args))
        _refuse_file_as_folder(output)
        if args.timeout is not None and not (math.isfinite(args.timeout) and args.timeout > 0):
            raise CosimError(f"must be a positive number of seconds, got {args.timeout}", element="--timeout")
        try:
            if args.no_supervise and args.timeout is None:
                _stop_on_sigterm()
                from .supervise import ScratchFolder
                with ScratchFolder():        # the unpacked SSP of a run killed here is swept by the next run
                    result = run(args.scenario, **options)
            else:
                from .supervise import run_supervised
                if args.no_supervise:
                    raise CosimError("--timeout needs the supervised run (drop --no-supervise)", element="--timeout")
                global _only_supervised
                _only_supervised = True
                result = run_supervised(args.scenario, timeout=args.timeout, **options)
        except CosimError as exc:
            res = getattr(exc, "result", None)
            meta = res.metadata if res is not None else {}
            if getattr(args, "debug", False):
                raise
            kept = (f" ({meta['rows_recorded']} rows recorded until then are in {output}, run.json says what "
                    "happened)" if meta.get("rows_recorded") else "")
            print(f"cosim-master: error: {exc}{kept}", file=sys.stderr)
            if meta.get("outcome") == "interrupted":
                return 143 if "SIGTERM" in str(exc) else 130
            return 1
        m = result.metadata
        ended = m.get("ended_early")
        print(f"{m['outcome']}: {m.get('steps_done', m['steps'])} steps of {m['step_size']:g} s ({m['algorithm']}), "
              f"{m.get('rows_recorded', 0)} rows in {result.output_dir}, wall {m['wall_time_s']:.2f} s"
              + (f"; ended at t={ended['time']:g} s: {ended['reason']}" if ended else ""))
        return 0
    if args.command == "inspect":
        from .inspect_scenario import format_inspect, inspect
        overrides = {k: v for k, v in (("step", args.step), ("stop_time", args.stop_time),
                                       ("algorithm", args.algorithm)) if v is not None}
        info = inspect(args.scenario, **overrides)
        import json
        print(json.dumps(info, indent=2, default=str) if args.json else format_inspect(info))
        return 0
    if args.command == "campaign":
        from .campaign.runner import run_campaign
        _stop_on_sigterm()      # as Ctrl-C: workers stopped, complete records kept, a last line saying so
        summary = run_campaign(args.campaign_yaml, output=args.output, workers=args.workers,
                               scheduler=args.scheduler, progress=not args.no_progress and _progress(None),
                               retry_failed=args.retry_failed, max_runs=args.max_runs)
        print(summary.describe())
        if summary.interrupted:          # as run: 130 after Ctrl-C, 143 after SIGTERM (README, docs/campaigns.md)
            return 143 if summary.interrupted == "SIGTERM" else 130
        return 0 if summary.ok else 1
    if args.command == "study":
        from .study import run_study
        summary = run_study(args.scenario, algorithms=args.algorithm, extrapolations=args.extrapolation,
                            steps=args.step, reference=args.reference, record=args.record, output=args.output,
                            workers=args.workers, scheduler=args.scheduler, stop_time=args.stop_time,
                            progress=not args.no_progress and _progress(None),
                            settings={k[len("sweep_"):]: v for k, v in vars(args).items() if k.startswith("sweep_")})
        print(summary.describe())
        stopped = getattr(getattr(summary, "campaign", None), "interrupted", False)
        if stopped:                     # its campaign was interrupted: as campaign and run
            return 143 if stopped == "SIGTERM" else 130
        return 0
    if args.command == "stability":
        from .stability.sweep import run_stability
        rows, paths = run_stability(args.scenario, algorithms=args.algorithm, extrapolations=args.extrapolation,
                                    interpolations=args.gs_interpolation, steps=args.step, output=args.output,
                                    params=_kv(args.param, "--param"), vary=args.vary)
        for r in rows:
            print(f"{r['scheme']:<24} h={r['step']:<8g}" + (f" {r['parameter']}={r['value']:<8g}" if r["parameter"]
                                                            else "")
                  + (f" spectral radius {r['spectral_radius']:.8f} (growth {r['growth_per_second']:+.3g}/s)"
                     + ("" if r["stable"] else "  unstable")
                     if not r["error"] else f" not identified: {r['error']}"))
        print("wrote " + ", ".join(map(str, paths)))
        return 0
    if args.command == "report":
        from .campaign.report import build_report
        path = build_report(args.campaign_dir, progress=_progress(args.progress))  # as campaign.json's kind writes it
        print(f"wrote {path}")
        return 0
    if args.command == "replay":
        from pathlib import Path

        from .scenario_kinds import kind_for_run
        run_dir = Path(args.run_dir)
        path = kind_for_run(run_dir).write_replay(run_dir, Path(args.scenario) if args.scenario else None)
        print(f"wrote {path}")
        return 0
    if args.command == "build-scenario":
        from pathlib import Path

        from .scenario_kinds import kind_for_file
        source = Path(args.scenario_yaml)
        path = kind_for_file(source).build(source, Path(args.output))
        print(f"wrote {path}")
        return 0
    return 2


if __name__ == "__main__":
    sys.exit(entry())
