"""The shipped UAV FMUs override pythonfmu's get/set methods; in process they must still give exactly what
their binaries give."""
from pathlib import Path

import master

SSP = Path(__file__).resolve().parents[3] / "ssp" / "paper_zones_4uav_B.ssp"


def test_uav_mission_in_process_equals_binary():
    # kept in memory: the rows and the events (the list events.csv is written from) are the subject, not the
    # mission's map and files, which cost most of a run with an output folder
    kw = dict(stop_time=60.0, step=0.5, record=["*"], record_interval=0.5)
    a = master.run(SSP, output=None, inprocess=True, **kw)
    b = master.run(SSP, output=None, inprocess=False, **kw)
    assert a.frame.equals(b.frame)
    assert a.frame["uav1_dyn.z"].max() > 5.0        # the vehicles really took off in these 60 s
    assert a.events and a.events == b.events
