"""cosim-master: an FMI/SSP fixed-step co-simulation master."""
__version__ = "0.1.0"

from .errors import CosimError, FmuError, ScenarioError  # noqa: E402


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
