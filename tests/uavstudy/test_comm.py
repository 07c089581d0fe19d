"""Strategy C through the study: the scenario's ``comm`` section, build-scenario's channel wiring, and whole runs of
the built SSP (the FMUs, the master, the UAV monitor): a silent channel gives B's results, a head-on departure
from the take-off ring collides under B and not under C, the channel's counts reach run.json, and a seed gives
the same run twice."""
from pathlib import Path

import pytest
import yaml
from lxml import etree
from master.errors import ScenarioError
from master.runner import run
from uavstudy.build import CHANNEL, build_scenario, default_fmu_dir
from uavstudy.comm_monitor import COMM_TYPE
from uavstudy.scenario import load_scenario_yaml
from uav_places import BASE, latlon

FMUS = ["UavDynamics.fmu", "UavBattery.fmu", "UavStrategy.fmu", "UavWind.fmu", "UavChannel.fmu"]
pytestmark = pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMUS),
                                reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")


def write_yaml(path: Path, **over) -> Path:
    d = {"name": path.stem, "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 2, "strategy": "C",
         "targets": [latlon(0, -250), latlon(0, 250)], "step": 0.1, "stop_time": 200.0, "seed": 3}
    d.update(over)
    path.write_text(yaml.safe_dump(d, sort_keys=False))
    return path


def _run(tmp_path, name, **over):
    ssp = build_scenario(write_yaml(tmp_path / f"{name}.yaml", **over), tmp_path / f"{name}.ssp")
    return run(ssp, output=tmp_path / name)


def _summary(result):
    import json
    return json.loads((result.output_dir / "summary.json").read_text())["total"]


# ------------------------------------------------------------------------------------------------ scenario
@pytest.mark.parametrize("comm,message", [
    ({"k": 5}, "comm.k: must be <= 4"),
    ({"loss": 1.5}, "comm.loss: must be <= 1"),
    ({"period": 0}, "comm.period: must be > 0"),
    ({"mode": "wifi"}, "comm.mode: must be one of radio, perfect, none"),
    ({"rnage": 100}, "comm.rnage: unknown field"),
    ({"los": "yes"}, "comm.los: expected true or false"),
])
def test_comm_section_validation(tmp_path, comm, message):
    with pytest.raises(ScenarioError) as ei:
        load_scenario_yaml(write_yaml(tmp_path / "bad.yaml", comm=comm))
    assert f"bad.yaml: {message}" in str(ei.value) and "\n" not in str(ei.value)


def test_strategy_c_fleet_is_bounded_by_the_channel(tmp_path):
    with pytest.raises(ScenarioError, match="n_uavs: 65 UAVs with strategy C, at most 64"):
        load_scenario_yaml(write_yaml(tmp_path / "big.yaml", n_uavs=65))
    assert load_scenario_yaml(write_yaml(tmp_path / "b.yaml", n_uavs=65, strategy="B")).n_uavs == 65


def _ssd(ssp_path):
    import zipfile
    with zipfile.ZipFile(ssp_path) as z:
        return etree.fromstring(z.read("SystemStructure.ssd"))


def test_build_wires_one_channel_with_k_slots_per_uav(tmp_path):
    ssp = build_scenario(write_yaml(tmp_path / "c.yaml", n_uavs=3, targets=[latlon(100, 0)] * 3,
                                    comm={"k": 2, "range": 150.0}), tmp_path / "c.ssp")
    root = _ssd(ssp)
    comps = [c.get("name") for c in root.iter("{*}Component")]
    assert comps.count(CHANNEL) == 1
    conns = [(c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
             for c in root.iter("{*}Connection")]
    to_channel = [c for c in conns if c[2] == CHANNEL]
    from_channel = [c for c in conns if c[0] == CHANNEL]
    assert len(to_channel) == 3 * 14                    # 8 Real + 6 Integer broadcast fields per UAV
    assert len(from_channel) == 3 * 2 * 15              # k = 2 slots of 15 fields per UAV
    assert ("uav2_dyn", "x", CHANNEL, "uav2_x") in conns
    assert ("uav3_strat", "intent_x", CHANNEL, "uav3_wx") in conns
    assert (CHANNEL, "uav1_m2_sender", "uav1_strat", "m2_sender") in conns
    assert not any(c[1].startswith("uav1_m3_") for c in from_channel)
    assert any(a.get("type") == COMM_TYPE for a in root.iter("{*}Annotation"))
    # A and B never get a channel, whatever the comm section says
    b = build_scenario(write_yaml(tmp_path / "b.yaml", strategy="B", comm={"range": 10.0}), tmp_path / "b.ssp")
    assert CHANNEL not in [c.get("name") for c in _ssd(b).iter("{*}Component")]


# ------------------------------------------------------------------------------------------------ runs
# two UAVs on the two pads of the ring (north (0, 4), south (0, -4)); the northern one's target lies south, the
# southern one's north: their paths out run head-on through each other's pad within seconds of take-off
HEAD_ON = dict(targets=[latlon(0, -250), latlon(0, 250)])


def test_head_on_departure_collides_under_b_not_under_c(tmp_path):
    b = _summary(_run(tmp_path, "b", strategy="B", **HEAD_ON))
    assert b["uav_collisions"] >= 1
    c_run = _run(tmp_path, "c", comm={"range": 300.0, "period": 0.5, "latency": 0.2}, **HEAD_ON)
    c = _summary(c_run)
    assert c["uav_collisions"] == 0 and c["targets_visited"] == 2 and c["uavs_successful"] == 2
    comm = c_run.metadata["monitors"][COMM_TYPE]
    assert comm["messages"]["sent"] > 0 and comm["messages"]["received"] > 0
    assert comm["uavs"]["uav2"]["give_ways"] >= 1 and comm["uavs"]["uav1"]["give_ways"] == 0
    assert (c_run.output_dir / "comm.json").is_file()


def test_c_on_a_silent_channel_gives_bs_results(tmp_path):
    spread = dict(n_uavs=3, targets=[latlon(150, 80), latlon(-120, 60), latlon(30, -170), latlon(-90, -90)],
                  wind={"probability": 0.1})
    b = _run(tmp_path, "b", strategy="B", **spread)
    c = _run(tmp_path, "c", comm={"mode": "none"}, **spread)
    fb, fc = b.frame, c.frame
    assert list(fb.columns) == [col for col in fc.columns if col in fb.columns]
    assert fb.equals(fc[list(fb.columns)])
    assert c.metadata["monitors"][COMM_TYPE]["messages"]["sent"] == 0
    sb, sc = _summary(b), _summary(c)
    assert {k: v for k, v in sb.items() if k not in ("scenario", "strategy")} == \
        {k: v for k, v in sc.items() if k not in ("scenario", "strategy")}


def test_same_seed_same_run_with_a_lossy_channel(tmp_path):
    over = dict(n_uavs=3, targets=[latlon(150, 80), latlon(-120, 60), latlon(30, -170)], stop_time=60.0,
                comm={"loss": 0.4, "latency": 0.3, "period": 0.3})
    one, two = _run(tmp_path, "one", **over), _run(tmp_path, "two", **over)
    assert one.frame.equals(two.frame)
    assert one.metadata["monitors"][COMM_TYPE] == two.metadata["monitors"][COMM_TYPE]
    lost = one.metadata["monitors"][COMM_TYPE]["messages"]
    assert lost["lost"] > 0
    other = _run(tmp_path, "other", seed=4, **over)
    assert other.metadata["monitors"][COMM_TYPE]["messages"]["lost"] != lost["lost"]


def test_lost_timeout_follows_the_loss(tmp_path):
    # an alive UAV in range stays unheard for T with probability loss^(T / period): T is set so that this is 1e-3
    import math

    from uavstudy.build import _lost_timeout
    for loss, expect in ((0.0, 5.0), (0.2, 5.0), (0.5, 0.5 * math.log(1e-3) / math.log(0.5) + 0.2),
                         (0.9, 0.5 * math.log(1e-3) / math.log(0.9) + 0.2), (0.99, 120.0)):
        scn = load_scenario_yaml(write_yaml(tmp_path / "t.yaml", comm={"loss": loss, "period": 0.5, "latency": 0.2}))
        assert _lost_timeout(scn) == pytest.approx(expect)
        assert loss == 0.0 or loss ** ((_lost_timeout(scn) - 0.2) / 0.5) <= 1e-3 + 1e-12 or expect == 120.0
