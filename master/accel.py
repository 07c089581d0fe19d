"""Accelerators: faster versions of a reference implementation, declared in one place.

Every hot concept (the step loop, an algorithm's step, a model's step, a monitor's step) has one reference
implementation in plain Python: the one the docs explain and a newcomer reads and changes. An accelerator
computes exactly the same thing faster (generated Python, C) and must give bit-identical results. Each one

- declares the reference it replaces (``replaces``, ``"module:qualname"``) and nothing else of it: it reads and
  writes the reference's state through public accessors or an explicit state structure, never private names;
- when it is C, is built by :mod:`master.native_build` (the one build path, also used when FMUs are built);
- is switched off, together with every other accelerator, by ``COSIM_MASTER_PURE_PYTHON=1`` (the one variable;
  code bundled into FMUs reads the same name without importing the engine);
- is published under the entry point group ``cosim_master.accelerators`` so that the shared harness
  (``tests/accelerators/``) finds it and checks it against its reference on the cases it generates.

Adding an accelerator is therefore one module plus one entry point; changing a reference is one place, and the
harness says which accelerator no longer agrees.  This module is a foundation (layer 0): it imports nothing of
the engine, and the engine's own accelerators are found by entry point like everybody else's.
"""
from __future__ import annotations

import os
import random
from typing import Any, Iterable, Protocol, runtime_checkable

#: the one variable that switches every accelerator off (the reference implementations run, only slower)
ENV = "COSIM_MASTER_PURE_PYTHON"
GROUP = "cosim_master.accelerators"


def enabled() -> bool:
    """False when ``COSIM_MASTER_PURE_PYTHON`` is set to anything but "" or "0"."""
    return os.environ.get(ENV, "") in ("", "0")


@runtime_checkable
class Accelerator(Protocol):
    """What the harness needs of an accelerator: a name, the reference it replaces, a way to load it, and cases
    on which to run both.  ``reference(case)`` and ``accelerated(impl, case)`` each return everything the case
    observes (outputs and the whole final state): the harness compares the two bit for bit."""

    name: str          #: unique, e.g. "uavsim.dynamics-step"
    replaces: str      #: the reference, "module:qualname"

    def load(self) -> tuple[Any | None, str | None]:
        """(the accelerated implementation, None), or (None, why it is not available here)."""

    def cases(self, rng: random.Random) -> Iterable[Any]:
        """Generated inputs and states, from ``rng`` only (so a failure can be reproduced from its seed)."""

    def reference(self, case: Any) -> Any:
        """The reference run on ``case``: what it returns and the state it leaves."""

    def accelerated(self, impl: Any, case: Any) -> Any:
        """The accelerator run on ``case``: the same shape as :meth:`reference`."""


def declared() -> dict[str, Accelerator]:
    """Every accelerator published under the entry point group, by name (loading each one's declaration only,
    not building it)."""
    from importlib.metadata import entry_points
    out: dict[str, Accelerator] = {}
    for ep in sorted(entry_points(group=GROUP), key=lambda e: e.name):
        out[ep.name] = ep.load()
    return out
