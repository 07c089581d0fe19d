"""The compiled channel step (uavsim/_channel_ext.c, ``uavsim.channel-step``) does the work itself.

The harness (test_against_reference.py) checks that it equals Channel.advance on generated fleets; it would also
pass if the compiled step declined every step (the Python step then runs).  Here: it takes the steps the FMU gives
it, decides a line of sight that a zone clearly blocks or clearly leaves free without asking ZoneMap.blocked, and
asks ZoneMap.blocked where the line passes a zone's corner closer than rounding and the zone's 1e-6 m shrinking
could tell apart.  Expectations are by hand: a 20 m square about the origin between or beside two UAVs."""
from __future__ import annotations

import random

import pytest

from uavsim import channel as C
from uavsim import zones_planning as Z
from uavsim.accelerators import CHANNEL_STEP

SQUARE = [[(-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)]]
FIELDS = C.BROADCAST_REAL + C.BROADCAST_INT


@pytest.fixture(scope="module")
def ext():
    impl, why = CHANNEL_STEP.load()
    if impl is None:
        pytest.skip(f"the compiled channel step is not available here: {why}")
    return impl


def _variables(points, clock):
    out = {}
    for i, (x, y) in enumerate(points):
        b = dict(x=x, y=y, z=20.0, vx=0.0, vy=0.0, wx=x, wy=y, clock=clock, state=2, target=-1, claims0=0,
                 claims1=0, visited0=0, visited1=0)
        out.update({f"uav{i}_{f}": b[f] for f in FIELDS})
    return out


def _one_send(ext, points, monkeypatch, calls):
    """Two UAVs at ``points`` broadcast once (t = 0, range 1 km, line of sight): (messages each received, blocked
    count), with ZoneMap.blocked's calls recorded."""
    real = Z.ZoneMap.blocked

    def recorded(self, a, b):
        calls.append((tuple(a), tuple(b)))
        return real(self, a, b)
    monkeypatch.setattr(Z.ZoneMap, "blocked", recorded)
    ch = C.Channel(C.ChannelParams(range=1e3, k=4, n_uavs=2, line_of_sight=True, zones=SQUARE))
    names = [tuple(f"uav{i}_{f}" for f in FIELDS) for i in range(2)]
    out = ext.advance(ch, 0.0, 0.1, _variables(points, 0.1), names)
    assert out is not NotImplemented
    return [len(m) for m in out] if out is not None else [0, 0], ch.counters["blocked"]


def test_a_zone_across_the_line_blocks_it_without_asking_shapely(ext, monkeypatch):
    calls = []
    assert _one_send(ext, [(-100.0, 0.0), (100.0, 0.0)], monkeypatch, calls) == ([0, 0], 2)
    assert calls == []


def test_a_line_beside_the_zone_is_clear_without_asking_shapely(ext, monkeypatch):
    calls = []
    # y = 25 + x / 8: at x = +-10 it is at 23.75 and 26.25 m, above the square's top (10 m)
    assert _one_send(ext, [(-100.0, 12.5), (100.0, 37.5)], monkeypatch, calls) == ([1, 1], 0)
    assert calls == []


@pytest.mark.parametrize("offset, blocked", [(1e-4, False), (-1e-4, True), (1e-7, False)])
def test_a_line_grazing_a_corner_is_left_to_zone_map(ext, monkeypatch, offset, blocked):
    """The line y = 10 + offset passes the square's top edge closer than the compiled test's margin (1 mm): it
    asks ZoneMap.blocked, once per direction, and follows its answer (above the edge: clear; 0.1 mm inside,
    beyond the 1e-6 m shrinking: blocked; 1e-7 m above the edge: clear)."""
    calls = []
    y = 10.0 + offset
    got = _one_send(ext, [(-100.0, y), (100.0, y)], monkeypatch, calls)
    assert got == (([0, 0], 2) if blocked else ([1, 1], 0))
    assert len(calls) == 2


def test_the_generated_fleets_are_stepped_by_the_compiled_code(ext):
    """On the harness's cases, the compiled step declines only the steps with a value it does not take (an int or
    a non-finite position, about 1 step in 100): otherwise the harness would compare Python with itself."""
    done = declined = 0
    for case in CHANNEL_STEP.cases(random.Random("handled")):
        ch = CHANNEL_STEP._channel(case)
        names = [tuple(f"uav{i + 1}_{f}" for f in FIELDS) for i in range(ch.n)]
        for t, h, uavs in case["steps"]:
            variables = {f"uav{i + 1}_{f}": b[f] for i, b in enumerate(uavs) for f in FIELDS}
            if ext.advance(ch, t, h, variables, names) is NotImplemented:
                declined += 1
                ch.advance(t, h, [(b["x"], b["y"], b["z"]) for b in uavs], [b["clock"] for b in uavs],
                           uavs.__getitem__)
            else:
                done += 1
    assert done > 3000 and declined < 0.05 * done
