"""The run options of a campaign (``run:``, also allowed as grid and runs keys): their names, which of them
change a run's results (and so are part of its input fingerprint), which a scenario carries itself, and their
checks."""
from __future__ import annotations

from ..algorithm_options import ALGORITHM_OPTIONS
from ..errors import CosimError

__all__ = ["ALGORITHM_RUN_OPTIONS", "RUN_OPTIONS", "RESULT_OPTIONS", "SCENARIO_OPTIONS", "check_options"]

#: the algorithms' settings (master.algorithm_options): run options too, and part of a run's results
ALGORITHM_RUN_OPTIONS = tuple(ALGORITHM_OPTIONS)
#: fixed run options (``run:``), also allowed as grid/runs keys
RUN_OPTIONS = ("stop_time", "start_time", "step", "algorithm", "record_interval", "record", "csv",
               "log_level", "timeout", "step_multiples") + ALGORITHM_RUN_OPTIONS
#: the run options that change a run's results (part of its input fingerprint)
RESULT_OPTIONS = ("stop_time", "start_time", "step", "algorithm", "record_interval", "record",
                  "step_multiples") + ALGORITHM_RUN_OPTIONS
#: the run options a scenario carries itself (an SSP's default experiment): a run option overrides them
SCENARIO_OPTIONS = ("stop_time", "step", "algorithm")


def check_options(err, where: str, opts: dict):
    """Check the values of the run options ``opts``; ``err(element, reason)`` raises the first problem, named
    ``where.option``."""
    for k in ("stop_time", "step", "record_interval", "timeout"):
        if k in opts and (isinstance(opts[k], bool) or not isinstance(opts[k], (int, float)) or opts[k] <= 0):
            err(f"{where}.{k}", f"expected a positive number, got {opts[k]!r}")
    if "start_time" in opts and (isinstance(opts["start_time"], bool) or
                                 not isinstance(opts["start_time"], (int, float))):
        err(f"{where}.start_time", f"expected a number, got {opts['start_time']!r}")
    if "algorithm" in opts:
        from ..algorithms import ALGORITHMS
        if opts["algorithm"] not in ALGORITHMS:
            err(f"{where}.algorithm", f"must be one of {', '.join(ALGORITHMS.names())}, got {opts['algorithm']!r}")
    for name in ALGORITHM_RUN_OPTIONS:
        if name in opts:
            try:
                ALGORITHM_OPTIONS[name].parse(opts[name], f"{where}.{name}")
            except CosimError as exc:
                err(exc.element, exc.reason)
    if "csv" in opts and not isinstance(opts["csv"], bool):
        err(f"{where}.csv", f"expected true or false, got {opts['csv']!r}")
    if "log_level" in opts and opts["log_level"] not in ("debug", "info", "warning", "error", "none"):
        err(f"{where}.log_level", f"must be debug, info, warning, error or none, got {opts['log_level']!r}")
    if "record" in opts and not (isinstance(opts["record"], list) and all(isinstance(x, str) for x in opts["record"])):
        err(f"{where}.record", "expected a list of patterns")
    if "step_multiples" in opts and not (isinstance(opts["step_multiples"], dict) and
                                         all(isinstance(x, int) and not isinstance(x, bool) and x >= 1
                                             for x in opts["step_multiples"].values())):
        err(f"{where}.step_multiples", "expected a mapping component -> integer >= 1")
