"""One error type for everything a user can get wrong or an FMU can do wrong.

The CLI prints ``str(error)`` as a single line, so every field that locates the
problem (file, line, element, simulation time) is part of that line.
"""
from __future__ import annotations


class CosimError(Exception):
    """A failure the user can act on: bad input, an FMU that cannot load or fails a step."""

    def __init__(self, reason: str, *, file: str | None = None, element: str | None = None,
                 line: int | None = None, time: float | None = None):
        self.reason = " ".join(str(reason).split())  # keep it on one line
        self.file = str(file) if file is not None else None
        self.element = element
        self.line = line
        self.time = time
        super().__init__(str(self))

    def __str__(self) -> str:
        parts = []
        if self.file:
            parts.append(f"{self.file}:{self.line}" if self.line else self.file)
        if self.element:
            parts.append(self.element)
        if self.time is not None:
            parts.append(f"t={self.time:.9g}")
        parts.append(self.reason)
        return ": ".join(parts)


class ScenarioError(CosimError):
    """The scenario (SSP, SSD, SSV, SSM, FMU description) is malformed or inconsistent."""


class FmuError(CosimError):
    """An FMU could not be loaded, or returned error, fatal or discard."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, turned into an interrupt so that a run in this process closes its results as for Ctrl-C."""
