"""events.csv without pandas (master.results.write_events_csv) is the bytes ``pandas.DataFrame(events).to_csv(
path, index=False)`` writes, compared on thousands of random event lists: keys in any order and missing from
some events, every kind of value a monitor emits (ints, floats of every magnitude, -0.0, NaN, bools, strings
that need quoting, None) and their mixtures.  Where the twin declines it writes nothing."""
import math
import random
import warnings

import numpy as np
import pandas as pd

from awkward_values import awkward_float

from master.results import write_events_csv

KEYS = ["time", "type", "event", "uav", "other", "x", "y", "lat", "distance", "consumed", "detail"]
STRINGS = ["takeoff", "uav_collision", "x, y", 'say "hi"', "two\nlines", "", "é"]


def _value(rng, kind):
    if rng.random() < 0.15:
        return None
    return {"int": lambda: rng.randint(-10 ** 6, 10 ** 6), "float": lambda: awkward_float(rng),
            "intfloat": lambda: rng.choice([rng.randint(-100, 100), awkward_float(rng)]),
            "bool": lambda: rng.random() < 0.5, "str": lambda: rng.choice(STRINGS),
            "mixed": lambda: rng.choice([3, -1.5, True, "a,b", math.nan, 2 ** 70, 2 ** 60, 0.5])}[kind]()


def _events(rng):
    kinds = {k: rng.choice(["int", "float", "intfloat", "bool", "str", "mixed"]) for k in KEYS}
    events = []
    for _ in range(rng.randint(1, 6)):
        keys = [k for k in KEYS if rng.random() < 0.85]
        if rng.random() < 0.3:
            rng.shuffle(keys)             # a later event may bring its keys in another order, or new ones
        events.append({k: _value(rng, kinds[k]) for k in keys})
    return events


def _pandas_bytes(tmp_path, events, to_file=True):
    """What pandas writes for ``events``: into a file (the call the twin stands in for), or (``to_file=False``) as
    the text ``to_csv`` returns, encoded as the file would be (UTF-8, no newline translation): the same bytes at
    about half the cost of pandas' file handling, and the test checks that they are the same on a sample."""
    path = tmp_path / "pandas.csv"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if not to_file:
                return pd.DataFrame(events).to_csv(index=False).encode("utf-8")
            pd.DataFrame(events).to_csv(path, index=False)
    except (TypeError, ValueError, OverflowError):
        return None
    return path.read_bytes()


def test_events_csv_is_what_pandas_writes(tmp_path):
    rng = random.Random(20261127)
    written = 0
    for i in range(1500):
        events = _events(rng)
        twin = tmp_path / "twin.csv"
        twin.unlink(missing_ok=True)
        expected = _pandas_bytes(tmp_path, events, to_file=False)
        if i % 25 == 0:         # pandas' text is its file's bytes (60 of the lists)
            assert _pandas_bytes(tmp_path, events) == expected, events
        if write_events_csv(events, twin):
            assert twin.read_bytes() == expected, events
            written += 1
        else:
            assert not twin.exists()
    assert written > 800          # all but some "mixed" columns (ints beyond 2**53 among floats, ...)


def test_the_uav_monitors_events_in_pandas_order(tmp_path):
    # as the UAV monitor emits them (uavstudy.monitor._event): the second event brings no "distance" key
    events = [{"time": 5.0, "type": "mission", "event": "takeoff", "uav": "uav1", "other": None, "x": 5.656854,
               "y": 0.0, "z": 0.0001, "lat": -7.274999999997105, "lon": -35.964948778299615, "alt": 540.0001025088131,
               "distance": None, "consumed": 0.0003222379329863516, "detail": ""},
              {"time": 812.25, "type": "zone", "event": "zone_incursion", "uav": "uav2", "other": "zone3",
               "x": -12.5, "y": 3e-7, "z": 20.0, "lat": -7.275, "lon": -35.965, "alt": 560.0, "consumed": None,
               "detail": "uav2 entered restricted zone zone3 (cut a corner, within the step)", "extra": 1}]
    assert write_events_csv(events, tmp_path / "twin.csv")
    assert (tmp_path / "twin.csv").read_bytes() == _pandas_bytes(tmp_path, events)
    lines = (tmp_path / "twin.csv").read_text().splitlines()
    assert lines[0] == "time,type,event,uav,other,x,y,z,lat,lon,alt,distance,consumed,detail,extra"
    assert lines[1].startswith("5.0,mission,takeoff,uav1,,5.656854,0.0,0.0001,") and lines[1].endswith(",,")


def test_values_outside_the_twin_are_left_to_pandas(tmp_path):
    for events in ([{"t": np.float64(1.5)}], [{"t": 1.0}, {"t": [1, 2]}], [{1: "a"}], []):
        assert not write_events_csv(events, tmp_path / "twin.csv")
        assert not (tmp_path / "twin.csv").exists()
