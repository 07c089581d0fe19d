"""cosim-master: an FMI/SSP fixed-step co-simulation master."""
__version__ = "0.1.0"

from .errors import CosimError, FmuError, ScenarioError  # noqa: E402


def run(scenario, **options):
    """Run a scenario; see master.runner.run for the options."""
    from .runner import run as _run
    return _run(scenario, **options)


def inspect(scenario, **options):
    """Describe a scenario without running it; see master.inspect_scenario.inspect."""
    from .inspect_scenario import inspect as _inspect
    return _inspect(scenario, **options)


__all__ = ["run", "inspect", "CosimError", "FmuError", "ScenarioError", "__version__"]
