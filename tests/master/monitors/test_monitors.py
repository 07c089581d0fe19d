"""The monitor plugin interface: switched on by an SSD annotation, reads values between steps, takes
components out (their outputs keep their last values), records events and may end the run early."""
import numpy as np
from lxml import etree

import master
from master.monitors import MONITORS, Monitor, register
from master.ssp.writer import SspBuilder

TYPE = "org.example.threshold"


@register(TYPE)
class Threshold(Monitor):
    """When `watch` reaches `level`, freeze component `freeze`; when it reaches `stop`, end the run."""

    def __init__(self, element, plan, shown_as):
        super().__init__(element, plan, shown_as)
        cfg = element[0]
        self.watch, self.freeze = cfg.get("watch"), cfg.get("freeze")
        self.level, self.stop = float(cfg.get("level")), float(cfg.get("stop"))
        self.frozen = False

    def required_variables(self):
        return [self.watch]

    def attach(self, ctx, start):
        super().attach(ctx, start)
        typ, self.pos = ctx.position(self.watch)
        self.buf = ctx.buffer(typ)

    def after_step(self, n, t0, t1):
        v = self.buf[self.pos]
        if not self.frozen and v >= self.level:
            self.frozen = True
            self.ctx.deactivate([self.freeze])
            self.ctx.emit({"time": t1, "type": "freeze", "value": float(v)})
        if v >= self.stop:
            self.ctx.request_stop(f"{self.watch} reached {self.stop}")

    def finish(self, out_dir, outcome):
        return {"frozen": self.frozen}


def _annotation(**attrs):
    ann = etree.Element("{http://ssp-standard.org/SSP1/SystemStructureCommon}Annotation", type=TYPE)
    etree.SubElement(ann, "{https://example.org/threshold}Threshold", **attrs)
    return ann


def test_monitor_freezes_a_component_and_ends_the_run(tmp_path, test_fmus):
    b = SspBuilder("mon", stop=10.0, step=0.1)
    b.add_component("one", test_fmus["c2:Integrator"], params={"x0": 1.0})
    b.add_component("clock", test_fmus["c2:Integrator"])          # clock.y = t
    b.add_component("other", test_fmus["c2:Integrator"])          # other.y = t until frozen
    b.connect("one", "y", "clock", "u")
    b.connect("one", "y", "other", "u")
    b.annotations.append(_annotation(watch="clock.y", freeze="other", level="0.45", stop="0.95"))
    r = master.run(b.write(tmp_path / "mon.ssp"), output=tmp_path / "out", record=["clock.y", "other.y"])
    assert TYPE in MONITORS
    df = r.frame
    # clock.y passes 0.45 after step 5 (t = 0.5): 'other' stops stepping and keeps other.y = 0.5
    np.testing.assert_allclose(df["clock.y"], df["time"], atol=1e-12)
    frozen = df["time"] >= 0.5 - 1e-12
    np.testing.assert_allclose(df.loc[frozen, "other.y"], 0.5, atol=1e-12)
    np.testing.assert_allclose(df.loc[~frozen, "other.y"], df.loc[~frozen, "time"], atol=1e-12)
    # the run ends after the step that brought clock.y past 0.95 (t = 1.0), not at the stop time 10
    assert r.ok and abs(df["time"].iloc[-1] - 1.0) < 1e-12
    assert r.metadata["ended_early"] == {"time": r.metadata["ended_early"]["time"], "reason": "clock.y reached 0.95"}
    assert abs(r.metadata["ended_early"]["time"] - 1.0) < 1e-12
    assert r.metadata["monitors"][TYPE] == {"frozen": True}
    events = (tmp_path / "out" / "events.csv").read_text().splitlines()
    assert events[0] == "time,type,value" and len(events) == 2
