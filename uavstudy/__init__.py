"""The multi-UAV surveillance study on top of the co-simulation master.

* :mod:`uavstudy.scenario` -- the scenario model: YAML and the paper's configuration files;
* :mod:`uavstudy.build` -- scenario -> SSP archive (``cosim-master build-scenario``);
* :mod:`uavstudy.monitor` -- the UAV monitor (collisions, zones, mission events), with
  :mod:`uavstudy.geometry` (swept collision and zone detection) and :mod:`uavstudy.outputs` (trajectory,
  photos, summary and map written after a run);
* :mod:`uavstudy.campaign_kind` -- the ``uav`` scenario kind of campaigns, :mod:`uavstudy.report` its report (a package);
* :mod:`uavstudy.names` -- the component, connector and code names all of them share.

The engine knows none of this: the monitor and the scenario kind reach it through the entry points
``cosim_master.monitors`` and ``cosim_master.scenario_kinds`` (pyproject.toml).
"""
