"""A UAV's track on map.png (uavstudy/outputs.py ``_track``) from the monitor's fleet track: that UAV's east-north
positions, in an array of its own, not a view that keeps the whole fleet's track alive (a map of 256 UAVs held
one copy of the fleet's track per UAV: +1.1 GB)."""
from types import SimpleNamespace

import numpy as np

from uavstudy.outputs import _track


def test_a_uav_track_is_its_own_column_of_the_fleet_track():
    n, steps = 64, 50
    t = np.arange(steps, dtype=float)
    # UAV k at (k + t, -k, 10 + k) at time t (one array per step, as the monitor appends them)
    track_p = [np.column_stack([np.arange(n) + tt, -np.arange(n, dtype=float), 10.0 + np.arange(n)]) for tt in t]
    mon = SimpleNamespace(track_t=list(t), track_p=track_p)
    for k in (0, 17, n - 1):
        times, xy = _track(mon, k, SimpleNamespace(removed_time=None), f"uav{k + 1}", None)
        np.testing.assert_array_equal(times, t)
        np.testing.assert_array_equal(xy, np.column_stack([k + t, np.full(steps, -float(k))]))
        # nothing larger than the UAV's own positions stays referenced through it
        assert xy.base is None or xy.base.nbytes <= xy.nbytes
    removed = _track(mon, 5, SimpleNamespace(removed_time=19.5), "uav6", None)      # cut at its removal
    np.testing.assert_array_equal(removed[0], t[:20])
