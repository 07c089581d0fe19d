"""Master settings from SSD annotations: our own, OMSimulator's and the Open Simulation Platform's.

Our annotation (type ``org.cosim-master.settings``, in DefaultExperiment or System annotations)::

    <cm:Settings xmlns:cm="https://cosim-master.org/ssp/settings" stepSize="0.1" algorithm="gauss-seidel"
                 recordInterval="1.0" extrapolation="1" couplingTol="1e-8">
      <cm:Component name="wind" stepMultiple="10"/>
      <cm:Record pattern="uav*.x"/>
    </cm:Settings>

Every algorithm setting of ``master.algorithm_options`` is an attribute too, in camelCase (extrapolation,
couplingTol, couplingAtol, couplingMaxIter, couplingUpdate, and those the algorithms register).

The algorithm is read as a name; whether an algorithm of that name is registered is asked where the run's
settings are resolved (``master.settings``), above the algorithms: reading an SSD needs no algorithm.

OMSimulator writes ``org.openmodelica`` / ``oms:FixedStepMaster stepSize``; OSP (libcosim) writes
``com.opensimulationplatform`` / ``osp:FixedStepAlgorithm baseStepSize``. Only the step size is taken
from those two, since their other settings have no counterpart here.
"""
from __future__ import annotations

from lxml import etree

from ..algorithm_options import ALGORITHM_OPTIONS
from ..errors import CosimError, ScenarioError
from .model import MasterSettings

OUR_TYPE = "org.cosim-master.settings"
OUR_NS = "https://cosim-master.org/ssp/settings"


def _local(el):
    return etree.QName(el).localname if isinstance(el.tag, str) else ""


def _iter_local(el, name):
    return (e for e in el.iter() if _local(e) == name)


def _positive(value, what, shown_as, el):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ScenarioError(f"{what}={value!r} is not a number", file=shown_as, element=_local(el),
                            line=el.sourceline) from None
    if not v > 0:
        raise ScenarioError(f"{what} must be positive, got {value}", file=shown_as, element=_local(el),
                            line=el.sourceline)
    return v


def _algorithm_options(el, s: MasterSettings, shown_as: str) -> None:
    for name, opt in ALGORITHM_OPTIONS.items():
        raw = el.get(opt.ssd_attribute)
        if raw is None:
            continue
        try:
            s.algorithm_options[name] = opt.parse(raw, opt.ssd_attribute)
        except CosimError as exc:
            raise ScenarioError(f"{opt.ssd_attribute}: {exc.reason}", file=shown_as, element=_local(el),
                                line=el.sourceline) from None


def read_master_settings(annotations: dict, shown_as: str) -> MasterSettings:
    s = MasterSettings()
    ours = annotations.get(OUR_TYPE)
    if ours is not None:
        for el in _iter_local(ours, "Settings"):
            if el.get("stepSize") is not None:
                s.step_size = _positive(el.get("stepSize"), "stepSize", shown_as, el)
                s.source = OUR_TYPE
            if el.get("recordInterval") is not None:
                s.record_interval = _positive(el.get("recordInterval"), "recordInterval", shown_as, el)
            if el.get("algorithm") is not None:
                s.algorithm, s.algorithm_line = el.get("algorithm"), el.sourceline
            _algorithm_options(el, s, shown_as)
            for c in _iter_local(el, "Component"):
                raw = c.get("stepMultiple", "1")
                try:
                    k = int(raw)
                except ValueError:
                    k = 0
                if k < 1:
                    raise ScenarioError(f"stepMultiple={raw!r} must be a positive integer", file=shown_as,
                                        element=f"Component {c.get('name')}", line=c.sourceline)
                s.step_multiples[c.get("name")] = k
            for r in _iter_local(el, "Record"):
                if r.get("pattern"):
                    s.record.append(r.get("pattern"))
    if s.step_size is None:
        oms = annotations.get("org.openmodelica")
        if oms is not None:
            for el in _iter_local(oms, "FixedStepMaster"):
                if el.get("stepSize") is not None:
                    s.step_size = _positive(el.get("stepSize"), "stepSize", shown_as, el)
                    s.source = "org.openmodelica"
                    break
    if s.step_size is None:
        osp = annotations.get("com.opensimulationplatform")
        if osp is not None:
            for el in _iter_local(osp, "FixedStepAlgorithm"):
                if el.get("baseStepSize") is not None:
                    s.step_size = _positive(el.get("baseStepSize"), "baseStepSize", shown_as, el)
                    s.source = "com.opensimulationplatform"
                    break
    return s
