"""The extrapolation order of one connection's source output, from an annotation on ``ssd:Connection``::

    <ssd:Connection startElement="A" startConnector="x" endElement="B" endConnector="x_in">
      <ssd:Annotations>
        <ssc:Annotation type="org.cosim-master.extrapolation">
          <cm:Extrapolation xmlns:cm="https://cosim-master.org/ssp/settings" order="1"/>
        </ssc:Annotation>
      </ssd:Annotations>
    </ssd:Connection>

``order`` is 0, 1 or 2, as ``--extrapolate A.x=1``; it applies to the connection's source output (every
connection from one output must agree; algorithms/extrapolation.py says why). Tools that do not know the
annotation type ignore it, as SSP 1.0 (section 2.2.4, ssc:Annotation) asks.
"""
from __future__ import annotations

from lxml import etree

from ..errors import ScenarioError
from .settings_annotations import OUR_NS

TYPE = "org.cosim-master.extrapolation"


def _local(el) -> str:
    return etree.QName(el).localname if isinstance(el.tag, str) else ""


def read_connection_order(conn_el, shown_as: str, element: str) -> int | None:
    """The order the connection's annotation asks for, or None without one."""
    for anns in (c for c in conn_el if _local(c) == "Annotations"):
        for ann in (a for a in anns if _local(a) == "Annotation" and a.get("type") == TYPE):
            found = [e for e in ann if _local(e) == "Extrapolation"]
            if len(found) != 1:
                raise ScenarioError(f"a {TYPE} annotation holds one cm:Extrapolation element, found {len(found)}",
                                    file=shown_as, element=element, line=ann.sourceline)
            raw = found[0].get("order")
            if raw is None or raw.strip() not in ("0", "1", "2"):
                raise ScenarioError(f"Extrapolation order must be 0, 1 or 2, got {raw!r}", file=shown_as,
                                    element=element, line=found[0].sourceline)
            return int(raw)
    return None


def write_connection_order(conn_el, order: int, q) -> None:
    """Append the annotation to ``conn_el`` (``q(prefix, name)``: the writer's qualified-name maker)."""
    if order not in (0, 1, 2):
        raise ValueError(f"extrapolation order must be 0, 1 or 2, not {order!r}")
    anns = etree.SubElement(conn_el, q("ssd", "Annotations"))
    ann = etree.SubElement(anns, q("ssc", "Annotation"), type=TYPE)
    etree.SubElement(ann, f"{{{OUR_NS}}}Extrapolation", order=str(order))
