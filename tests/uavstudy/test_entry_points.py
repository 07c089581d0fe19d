"""The UAV study reaches the engine through its registries (entry points in pyproject.toml)."""
from pathlib import Path

from master.monitors import MONITORS
from master.scenario_kinds import SCENARIO_KINDS, kind_claiming
from uavstudy.campaign_kind import UavKind
from uavstudy.monitor import UavMonitor

ROOT = Path(__file__).resolve().parents[2]


def test_uav_monitor_is_found_by_its_annotation_type():
    assert MONITORS.find("org.cosim-master.uav-monitor") is UavMonitor


def test_uav_scenario_kind_is_found_and_claims_yaml_scenarios():
    kind = SCENARIO_KINDS.get("uav")
    assert isinstance(kind, UavKind) and kind.name == "uav"
    assert set(SCENARIO_KINDS.names()) >= {"ssp", "uav"}
    assert kind_claiming(ROOT / "ssp" / "scenarios" / "paper_area.yaml") is kind
    assert kind_claiming(ROOT / "ssp" / "paper_zones_4uav_B.ssp").name == "ssp"
