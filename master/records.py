"""``Record``: a representation and equality by the instance's attributes, for the run path's plain record classes.

They are plain classes with a hand-written ``__init__`` rather than dataclasses because Python 3.11 compiles a
dataclass's generated methods from source, with one ``exec`` each, in every process that defines it: ~3 M
instructions a class of a short run's start-up (bench/results/startup_2026-11-29b.md). ``repr`` reads as a
dataclass's (``Unit(name='m', factor=1.0, ...)``), equality compares the attributes of two instances of one class,
and an instance is not hashable, as with a dataclass that is neither frozen nor told otherwise."""
from __future__ import annotations


class Record:
    __slots__ = ()
    __hash__ = None

    def __repr__(self):
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in vars(self).items())})"

    def __eq__(self, other):
        return vars(self) == vars(other) if other.__class__ is self.__class__ else NotImplemented


def replaced(record, **changes):
    """A shallow copy of ``record`` with ``changes``: what ``dataclasses.replace`` made, by the instance's
    ``__dict__`` instead of a construction argument by argument (copy.copy's reduce protocol cost more still) --
    the plan and the parser copy a few hundred records a run. Only for classes whose ``__init__`` stores its
    arguments and nothing else (the records here, ``plan.model.Var``); the names in ``changes`` are not checked."""
    out = object.__new__(type(record))
    d = out.__dict__
    d.update(record.__dict__)
    d.update(changes)
    return out
