"""A plan's per-component variables (master/plan.py ComponentVariables): every variable of the modelDescription,
in its order, but a Var object only for those asked for."""
from __future__ import annotations

import zipfile
from pathlib import Path
from xml.etree import ElementTree

from master.execution import prepare
from master.observers.recording import select_variables

REPO = Path(__file__).resolve().parents[3]
SSP = REPO / "ssp" / "paper_zones_4uav_B.ssp"


def _model_variables(fmu: Path) -> list[str]:
    with zipfile.ZipFile(fmu) as z:
        root = ElementTree.fromstring(z.read("modelDescription.xml"))
    return [sv.get("name") for sv in root.iter("ScalarVariable")]


def test_every_variable_in_order_but_made_when_asked_for():
    names = _model_variables(REPO / "fmus" / "UavStrategy.fmu")
    p = prepare(SSP)
    try:
        strat = p.plan.variables["uav1_strat"]
        assert list(strat) == names and len(strat) == len(names) > 1000
        # the plan looked up the SSD's connectors and parameter values only: a tenth of the 1211
        asked = set(p.model.components["uav1_strat"].connectors) | {
            pv.variable for pv in p.model.parameters if pv.component == "uav1_strat"}
        assert set(strat._made) <= asked and len(asked) < len(names) / 5
        v = strat["target_x_3"]
        assert (v.component, v.name, v.qualified) == ("uav1_strat", "target_x_3", "uav1_strat.target_x_3")
        assert strat["target_x_3"] is v and "target_x_3" in strat and "nothing" not in strat
        assert strat.get("nothing") is None
        other = p.plan.variables["uav2_strat"]["target_x_3"]
        assert other.component == "uav2_strat" and (other.vr, other.type) == (v.vr, v.type)
        assert p.plan.var("uav2_strat.target_x_3") is other
    finally:
        p.source.close()


def test_record_patterns_select_by_name():
    p = prepare(SSP)
    try:
        made_before = len(p.plan.variables["uav3_strat"]._made)
        chosen = select_variables(p.plan, ["uav3_strat.target_x_*", "uav3_strat.n_targets"], [])
        # the modelDescription's order: n_targets, then target_x_k/target_y_k for k = 1..64
        assert [v.name for v in chosen] == ["n_targets"] + [f"target_x_{k}" for k in range(1, 65)]
        assert all(v.component == "uav3_strat" for v in chosen)
        assert len(p.plan.variables["uav3_strat"]._made) <= made_before + 65
    finally:
        p.source.close()
