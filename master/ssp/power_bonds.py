"""Power bonds declared in an SSD (annotation type ``org.cosim-master.power-bonds``), for ECCO.

A power bond joins two components X and Y by two connections of the SSD: the *effort* (force, voltage,
pressure, torque) that Y outputs and X reads, and the *flow* (velocity, current, volume flow, angular
velocity) that X outputs and Y reads (Sadjina et al. 2017; bond graphs, Karnopp, Margolis and Rosenberg).
The power through the bond is effort x flow, seen from each side with its own input and output::

    <ssd:Annotations>
      <ssc:Annotation type="org.cosim-master.power-bonds">
        <cm:PowerBonds xmlns:cm="https://cosim-master.org/ssp/power-bonds">
          <cm:PowerBond name="spring">
            <cm:Effort startElement="B" startConnector="F" endElement="A" endConnector="F"/>
            <cm:Flow startElement="A" startConnector="v" endElement="B" endConnector="v_in"/>
          </cm:PowerBond>
        </cm:PowerBonds>
      </ssc:Annotation>
    </ssd:Annotations>

Effort and Flow name connections that exist in the SSD (same four attributes as ``ssd:Connection``), both
Real; the effort ends where the flow starts (X = A) and starts where the flow ends (Y = B).
"""
from __future__ import annotations

from lxml import etree

from ..errors import ScenarioError
from ..records import Record

POWER_BONDS_TYPE = "org.cosim-master.power-bonds"
POWER_BONDS_NS = "https://cosim-master.org/ssp/power-bonds"


class PowerBond(Record):
    """A plain class, not a dataclass (``master.records`` says why)."""
    def __init__(self, name: str, effort, flow):
        self.name = name
        self.effort = effort    # plan.Link: Y's effort output -> X's effort input
        self.flow = flow        # plan.Link: X's flow output -> Y's flow input


def _local(el) -> str:
    return etree.QName(el).localname if isinstance(el.tag, str) else ""


def read_power_bonds(plan) -> list[PowerBond]:
    """The power bonds of the plan's SSD, checked against its connections; [] when none are declared."""
    ann = plan.model.annotations.get(POWER_BONDS_TYPE)
    if ann is None:
        return []
    links = {(ln.src.qualified, ln.dst.qualified): ln for ln in plan.links if ln.src is not None}
    bonds, names = [], set()
    for el in ann.iter():
        if _local(el) != "PowerBond":
            continue
        name = el.get("name") or f"bond{len(bonds) + 1}"
        where = dict(file=plan.shown_as, element=f"PowerBond {name}", line=el.sourceline)
        if name in names:
            raise ScenarioError("a second power bond of this name", **where)
        names.add(name)
        ends = {}
        for kind in ("Effort", "Flow"):
            found = [c for c in el if _local(c) == kind]
            if len(found) != 1:
                raise ScenarioError(f"needs exactly one {kind} connection, found {len(found)}", **where)
            c = found[0]
            missing = [a for a in ("startElement", "startConnector", "endElement", "endConnector") if not c.get(a)]
            if missing:
                raise ScenarioError(f"{kind} lacks the attribute{'s' if len(missing) > 1 else ''} {', '.join(missing)}",
                                    **where)
            src, dst = f"{c.get('startElement')}.{c.get('startConnector')}", f"{c.get('endElement')}.{c.get('endConnector')}"
            link = links.get((src, dst))
            if link is None:
                raise ScenarioError(f"{kind} {src} -> {dst} is not a connection of the system", **where)
            if link.src.type != "Real":
                raise ScenarioError(f"{kind} {src} -> {dst} is not a Real connection", **where)
            ends[kind] = link
        effort, flow = ends["Effort"], ends["Flow"]
        if not (effort.dst.component == flow.src.component and effort.src.component == flow.dst.component
                and effort.src.component != effort.dst.component):
            raise ScenarioError(f"the effort must go from one component to the other ({effort.src.component} -> "
                                f"{effort.dst.component}) and the flow back ({flow.src.component} -> "
                                f"{flow.dst.component})", **where)
        bonds.append(PowerBond(name, effort, flow))
    return bonds


def power_bonds_annotation(bonds: list[tuple[str, tuple[str, str, str, str], tuple[str, str, str, str]]]):
    """The annotation element for ``SspBuilder.annotations``: (name, effort connection, flow connection) with
    each connection as (startElement, startConnector, endElement, endConnector)."""
    ssc = "http://ssp-standard.org/SSP1/SystemStructureCommon"
    ann = etree.Element(f"{{{ssc}}}Annotation", type=POWER_BONDS_TYPE, nsmap={"ssc": ssc})
    root = etree.SubElement(ann, f"{{{POWER_BONDS_NS}}}PowerBonds", nsmap={"cm": POWER_BONDS_NS})
    keys = ("startElement", "startConnector", "endElement", "endConnector")
    for name, effort, flow in bonds:
        b = etree.SubElement(root, f"{{{POWER_BONDS_NS}}}PowerBond", name=name)
        etree.SubElement(b, f"{{{POWER_BONDS_NS}}}Effort", **dict(zip(keys, effort)))
        etree.SubElement(b, f"{{{POWER_BONDS_NS}}}Flow", **dict(zip(keys, flow)))
    return ann
