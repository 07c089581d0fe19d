"""The monitor interface: an observer switched on by an SSD annotation."""
from __future__ import annotations

from ..observers.base import Observer, ObserverContext

MonitorContext = ObserverContext


class Monitor(Observer):
    annotation_type = ""
    products = "all"      # "summary": a campaign wants the summary files only (set by run(products=...))

    def __init__(self, element, plan, shown_as: str):
        self.element = element
        self.plan = plan
        self.shown_as = shown_as
