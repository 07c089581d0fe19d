"""The UAVs flown by ArduCopter SITL (UavSitl.fmu, docs/sitl.md) as forwarded vehicles (forward.py).

A UAV is SITL-backed when its dynamics component has the output ``sitl_instance`` (the instance N that SITL
started on, known after initialisation).  Its firmware's SERIAL0 (TCP 5760+10N) is the FMU's own link; SITL
also serves MAVLink on SERIAL1 (TCP 5762+10N, SERIAL1_PROTOCOL 2 in ArduCopter's defaults and copter.parm;
measured: it binds once SERIAL0 has its client and sends HEARTBEAT from the ``--sysid`` given).  The ground
stations get that port's stream.  The system id is the component's parameter ``sysid`` (SITL's ``--sysid``);
the scenario builder gives UAV k the id k (uavstudy/build.py), UavSitl's default is 1.
"""
from __future__ import annotations

from master.errors import CosimError

from ..names import DYNAMICS, component
from .fleet import _param
from .forward import Forwarded, register_source

INSTANCE_OUTPUT = "sitl_instance"
#: UavSitl's Boolean parameter: false starts SITL without SERIAL1 (a headless fleet, scenario ``sitl.gcs_port``)
GCS_PORT_PARAMETER = "gcs_port"
SYSID_PARAMETER, SYSID_DEFAULT = "sysid", 1
#: SITL instance N serves SERIAL1 on this port + 10 N (fmu_sources/sitlsim/process.py: ports)
SERIAL1_BASE = 5762


def _serial1(uav: str, instance_var: str):
    def url(read) -> str:
        n = int(read(instance_var))
        if n < 0:
            raise CosimError(f"{uav}: its SITL has not started ({instance_var} = {n}), no stream to forward",
                             element="--mavlink")
        return f"tcp:127.0.0.1:{SERIAL1_BASE + 10 * n}"
    return url


@register_source
def sitl_vehicles(monitor, plan) -> list[Forwarded]:
    variables = getattr(plan, "variables", {})
    out = []
    for u in monitor.cfg.uavs:
        dyn = component(u.name, DYNAMICS)
        if INSTANCE_OUTPUT in variables.get(dyn, {}):
            var = f"{dyn}.{INSTANCE_OUTPUT}"
            sysid = int(_param(plan, f"{dyn}.{SYSID_PARAMETER}", SYSID_DEFAULT))
            if not _param(plan, f"{dyn}.{GCS_PORT_PARAMETER}", 1.0):
                raise CosimError(f"{u.name}: its SITL runs without a ground-station port ({dyn}.{GCS_PORT_PARAMETER} "
                                 f"false, scenario sitl.gcs_port), so its stream cannot be forwarded", element="--mavlink")
            out.append(Forwarded(u.name, _serial1(u.name, var), sysid, (var,)))
    return out
