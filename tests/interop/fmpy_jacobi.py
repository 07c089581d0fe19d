"""A plain Jacobi master for a flat SSP, written with fmpy's FMI 2.0 calls, to tell which calling sequence a
result comes from (run as a script: the FMUs' native code stays out of the test process).

    python fmpy_jacobi.py SSP OUT.csv STOP STEP [--set COMPONENT.VARIABLE=VALUE ...] [--like-omsimulator]

Every FMU gets fmi2SetupExperiment(tolerance 1e-4, start 0, no stop time), the ``--set`` values before it, the
connections' values in Initialization Mode, and then at every communication point its inputs before one
fmi2DoStep.  OUT has ``time`` and ``<component>.<variable>`` of every Real variable after initialisation and after
every step (before the next inputs are set).

Without options the calls are what FMI 2.0 allows in co-simulation: every connection's source is read after the
step, then the inputs are set, then each FMU steps, from the communication point n * STEP by STEP.

``--like-omsimulator`` makes the calls OMSimulator 2940ef11's ``oms_ma`` makes (traced under gdb):

* each connection's target is set right after its source is read, in the SSD's order (a direct-feedthrough
  output is read after its own inputs are set);
* every Real variable of every FMU is read after the inputs are set, before fmi2DoStep (OMSimulator records its
  results there too).  FMI 2.0's co-simulation state machine does not allow an fmi2GetXXX after an fmi2SetXXX
  without an fmi2DoStep in between; an FMU that evaluates itself in that read steps differently;
* its clock is a sum, t + STEP, and fmi2DoStep gets the difference (t + STEP) - t; a step past STOP ends at
  STOP.  (A sum that falls short of STOP, where OMSimulator adds a step of the remainder, is not reproduced.)
"""
from __future__ import annotations

import argparse
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

SSD = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
INTEGERS = ("Integer", "Enumeration", "Boolean")


class Unit:
    """One FMU: its slave and its variables by name."""

    def __init__(self, name: str, fmu: Path, folder: Path):
        md = read_model_description(str(fmu), validate=False)
        self.name = name
        self.vars = {v.name: v for v in md.modelVariables}
        self.reals = [v for v in md.modelVariables if v.type == "Real"]
        self.slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu), unzipdir=str(folder)), instanceName=name,
                               modelIdentifier=md.coSimulation.modelIdentifier)
        self.slave.instantiate()

    def get(self, name: str):
        v = self.vars[name]
        if v.type == "Boolean":
            return self.slave.getBoolean([v.valueReference])[0]
        getter = self.slave.getInteger if v.type in INTEGERS else self.slave.getReal
        return getter([v.valueReference])[0]

    def set(self, name: str, value) -> None:
        v = self.vars[name]
        if v.type == "Boolean":
            self.slave.setBoolean([v.valueReference], [bool(value)])
        elif v.type in INTEGERS:
            self.slave.setInteger([v.valueReference], [int(value)])
        else:
            self.slave.setReal([v.valueReference], [float(value)])

    def read_reals(self) -> list:
        return list(self.slave.getReal([v.valueReference for v in self.reals]))


def run(ssp: Path, stop: float, step: float, values: dict, like_omsimulator: bool) -> pd.DataFrame:
    with tempfile.TemporaryDirectory() as tmp:
        with zipfile.ZipFile(ssp) as z:
            z.extractall(tmp)
        root = ET.parse(Path(tmp) / "SystemStructure.ssd").getroot()
        units = {c.get("name"): Unit(c.get("name"), Path(tmp) / c.get("source"), Path(tmp) / "fmus" / c.get("name"))
                 for c in root.iter(SSD + "Component")}
        links = [(units[c.get("startElement")], c.get("startConnector"), units[c.get("endElement")],
                  c.get("endConnector")) for c in root.iter(SSD + "Connection")]
        for key, value in values.items():
            component, variable = key.split(".", 1)
            units[component].set(variable, value)
        for u in units.values():
            u.slave.setupExperiment(tolerance=1e-4, startTime=0.0)
            u.slave.enterInitializationMode()

        def transfer(in_order: bool):
            if in_order:
                for src, out, dst, inp in links:
                    dst.set(inp, src.get(out))
            else:
                for dst, inp, value in [(dst, inp, src.get(out)) for src, out, dst, inp in links]:
                    dst.set(inp, value)

        def row(t: float) -> list:
            return [t] + [x for u in units.values() for x in u.read_reals()]

        transfer(like_omsimulator)
        for u in units.values():
            u.slave.exitInitializationMode()
        rows = [row(0.0)]
        t = 0.0
        for n in range(1, int(round(stop / step)) + 1):
            if n > 1:
                transfer(like_omsimulator)
            if like_omsimulator:
                row(t)                                 # read after the inputs are set, before the step
            t_next = min(t + step, stop) if like_omsimulator else n * step
            for u in units.values():
                u.slave.doStep(t, t_next - t if like_omsimulator else step)
            t = t_next
            rows.append(row(n * step))
        columns = ["time"] + [f"{u.name}.{v.name}" for u in units.values() for v in u.reals]
        for u in units.values():
            u.slave.terminate()
            u.slave.freeInstance()
        return pd.DataFrame(np.array(rows), columns=columns)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("ssp", type=Path)
    p.add_argument("out", type=Path)
    p.add_argument("stop", type=float)
    p.add_argument("step", type=float)
    p.add_argument("--set", action="append", default=[], metavar="COMPONENT.VARIABLE=VALUE")
    p.add_argument("--like-omsimulator", action="store_true")
    a = p.parse_args(argv)
    values = dict(s.split("=", 1) for s in a.set)
    run(a.ssp, a.stop, a.step, values, a.like_omsimulator).to_csv(a.out, index=False, float_format="%.17g")


if __name__ == "__main__":
    main()
