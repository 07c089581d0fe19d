"""``run``: a whole run in one call, a thin function over :class:`master.execution.Execution`."""
from __future__ import annotations

from pathlib import Path

from .errors import CosimError, Terminated
from .execution import Execution
from .records import Record


class Result(Record):
    """What ``run`` returns: the output folder (None: kept in memory), run.json's facts and the events. A plain
    class, not a dataclass (``master.records`` says why)."""
    def __init__(self, output_dir: Path | None, metadata: dict, events: list | None = None, _table=None):
        self.output_dir, self.metadata = output_dir, metadata
        self.events = [] if events is None else events
        self._table = _table

    @property
    def ok(self) -> bool:
        return self.metadata.get("outcome") == "completed"

    @property
    def frame(self):
        """The recorded time series as a pandas DataFrame (columns 'time' and 'component.variable')."""
        if self._table is not None:
            return self._table.to_pandas()
        from .results import read_results
        return read_results(self.output_dir)


def run(scenario, *, raise_on_error: bool = True, observers=(), manipulators=(), **options) -> Result:
    """Run a scenario (.ssp archive, unpacked SSP folder, .ssd file, or a system built in code:
    ``master.ssp.writer.SspBuilder``) from its start to its stop time (or until an observer ends it) and return
    its recorded results. The options are those of :class:`master.execution.Options`; without ``output`` the
    results are kept in memory (``Result.frame``) and nothing is written.

    On a failure the results recorded so far stay on disk, run.json says what happened, and a CosimError is
    raised (or, with ``raise_on_error=False``, returned in the Result's metadata).
    """
    ex = Execution(scenario, observers=observers, manipulators=manipulators, **options)
    error: CosimError | None = None
    try:
        try:
            ex.initialize()
            ex.simulate_until()
            ex.close("completed")
        except CosimError as exc:
            error = exc
            ex.close("error", exc)
        except KeyboardInterrupt as exc:
            # one that came while the completed run was written was held until its files were whole: nothing was
            # cut, so the run is what its run.json says, completed (the exit status and message agree with it)
            if not (ex.closed and ex.metadata.get("outcome") == "completed"):
                why = "stopped by SIGTERM" if isinstance(exc, Terminated) else "interrupted by the user"
                error = CosimError(why, time=ex.metadata.get("last_time"))
                ex.close("interrupted", error)
        finally:
            ex.close()       # any other exception: the run's files are still closed and run.json written
    except OSError as exc:
        # the run's own files (fmu.log, run.json) could not be written either: a full disk is one line too
        from .sinks.group import write_failure
        ex.metadata["outcome"] = "error"
        if error is None:
            error = CosimError(write_failure(exc, exc.filename or str(ex.out_dir)), element="results")
    if error is None and ex.metadata.get("outcome") == "error":
        # the simulation ended but closing it failed (its last rows did not fit on the disk): a failed run, as
        # run.json says, not a completed one
        error = CosimError(ex.metadata.get("error") or "the run's results could not be written")
    result = Result(ex.out_dir, ex.metadata, ex.events, ex.memory_table() if ex.out_dir is None else None)
    if error is not None:
        error.result = result
        if raise_on_error:
            raise error
    return result
