"""cosim-master: an FMI/SSP fixed-step co-simulation master."""
from ._version import __version__
from .errors import CosimError, FmuError, ScenarioError


def run(scenario, **options):
    """Run a scenario from start to stop; see master.runner.run and master.execution.Options."""
    from .runner import run as _run
    return _run(scenario, **options)


def __getattr__(name):   # lazy: ``import master`` stays cheap (campaign workers, the CLI's --help)
    if name == "Execution":
        from .execution import Execution
        return Execution
    if name == "SspBuilder":
        from .ssp.writer import SspBuilder
        return SspBuilder
    raise AttributeError(name)


def inspect(scenario, **options):
    """Describe a scenario without running it; see master.inspect_scenario.inspect."""
    from .inspect_scenario import inspect as _inspect
    return _inspect(scenario, **options)


__all__ = ["run", "inspect", "Execution", "SspBuilder", "CosimError", "FmuError", "ScenarioError", "__version__"]
