"""The shipped UAV FMUs override pythonfmu's get/set methods; in process they must still give exactly what
their binaries give."""
from pathlib import Path

import master

SSP = Path(__file__).resolve().parents[3] / "ssp" / "paper_zones_4uav_B.ssp"


def test_uav_mission_in_process_equals_binary(tmp_path):
    kw = dict(stop_time=60.0, step=0.5, record=["*"], record_interval=0.5)
    a = master.run(SSP, output=tmp_path / "a", inprocess=True, **kw)
    b = master.run(SSP, output=tmp_path / "b", inprocess=False, **kw)
    assert a.frame.equals(b.frame)
    assert a.frame["uav1_dyn.z"].max() > 5.0        # the vehicles really took off in these 60 s
    assert (tmp_path / "a" / "events.csv").read_text() == (tmp_path / "b" / "events.csv").read_text()
