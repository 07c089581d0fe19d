"""Live streams: a run shown to (and steered from) an outside tool while it runs, e.g. a ground station.

The engine knows a live stream only by the run option that asks for it (``Options.mavlink``: the
addresses to stream to) and the registry ``LIVE`` (entry point group ``cosim_master.live``, key = the
option's name).  A study publishes the stream that understands its scenarios (the UAV study:
``uavstudy.mavlink``).  The stream's ``open`` gives an observer/manipulator pair that the execution puts
beside the monitors and the recording; the step loop itself does not change, so a streamed run computes
exactly what an unstreamed one does.  Campaigns never stream (their run options do not include these).
"""
from __future__ import annotations

from typing import NamedTuple

from .errors import CosimError
from .registry import Registry

#: run options (``Options`` fields, ``--`` + name on the command line) that ask for a live stream
LIVE_OPTIONS = ("mavlink",)


class LiveParts(NamedTuple):
    observers: list          # after the monitors (they see the monitors' events of the step), before recording
    manipulators: list       # before every step (commands from the outside)


class LiveStream:
    """What a study publishes under ``cosim_master.live``."""

    def check(self, urls: list[str]) -> None:
        """Refuse unusable addresses before anything runs (a CosimError naming the option)."""

    def open(self, urls: list[str], *, monitors: list, plan, settings, options) -> LiveParts:
        """Connect (bind, listen) and return the parts that stream this run; a CosimError naming the option
        when the scenario has nothing this stream can show or an address cannot be used."""
        raise NotImplementedError


LIVE: Registry[LiveStream] = Registry("live stream", "cosim_master.live")


def requested(options) -> dict[str, list[str]]:
    """Live option name -> addresses, for the live options given."""
    out = {}
    for name in LIVE_OPTIONS:
        value = getattr(options, name, None)
        if value:
            out[name] = [value] if isinstance(value, str) else list(value)     # one address or several
    return out


def check_options(options) -> None:
    """The live and pacing options, checked before the output folder is claimed (a typo must not cost an
    earlier run's results)."""
    if options.realtime is not None and not (options.realtime > 0):
        raise CosimError(f"must be a positive factor of the wall clock, got {options.realtime}", element="--realtime")
    for name, urls in requested(options).items():
        stream_for(name).check(urls)


def stream_for(name: str) -> LiveStream:
    found = LIVE.find(name)
    if found is None:
        raise CosimError(f"no installed package streams {name} (entry point group {LIVE.group})",
                         element=f"--{name}")
    return found


def open_streams(options, monitors, plan, settings) -> LiveParts:
    observers, manipulators = [], []
    if requested(options):
        from .log import logger
        logger()        # a stream's module logs to the engine's logger itself: set up as asked (master.log)
    for name, urls in requested(options).items():
        parts = stream_for(name).open(urls, monitors=monitors, plan=plan, settings=settings, options=options)
        observers += parts.observers
        manipulators += parts.manipulators
    return LiveParts(observers, manipulators)
