"""The names the UAV study's modules agree on: components, connectors, phase and mission-state codes.

The scenario builder writes them into the SSP, the monitor and the outputs read them back, the campaign
and the report look for them in the results; keeping them here means a rename is one edit.  The codes
are the FMUs' own (``uavsim.dynamics`` phases, ``uavsim.strategy`` mission states), imported rather than
repeated so that the study cannot drift from the physics it observes.
"""
from __future__ import annotations

from uavsim.dynamics import FLY, LAND, LANDED, PREFLIGHT, TAKEOFF
from uavsim.strategy import (LAND_BASE, LAND_NOW, LANDED_AWAY, LANDED_BASE, RETURN_DONE, RETURN_LOW, TRANSIT)
from uavsim.strategy import PREFLIGHT as STATE_PREFLIGHT
from uavsim.strategy import TAKEOFF as STATE_TAKEOFF
from uavsim.strategy import LAND_CMD, RETURN_CMD

# ------------------------------------------------------------------------------------- the SSD annotation
MONITOR_TYPE = "org.cosim-master.uav-monitor"
UAV_NS = "https://cosim-master.org/ssp/uav"

# ------------------------------------------------------------------------------------- components
#: the one wind component every UAV's dynamics share
WIND = "wind"
#: the parts of one UAV; its components are named ``uav{k}_{part}`` (see :func:`component`)
DYNAMICS, BATTERY, STRATEGY = "dyn", "bat", "strat"
UAV_PARTS = (DYNAMICS, BATTERY, STRATEGY)


def uav_name(index: int) -> str:
    """The name of the UAV with 0-based ``index`` (uav1, uav2, ...)."""
    return f"uav{index + 1}"


def component(uav: str, part: str) -> str:
    """The component of one part of a UAV (``uav`` may be a pattern such as ``uav*``)."""
    return f"{uav}_{part}"


# ------------------------------------------------------------------------------------- monitor connectors
#: role (attribute of ``uav:Uav`` in the monitor annotation) -> (part, output variable) it names; the
#: first four are required, the monitor reads the others when present
MONITOR_CONNECTORS = {
    "x": (DYNAMICS, "x"), "y": (DYNAMICS, "y"), "z": (DYNAMICS, "z"), "phase": (DYNAMICS, "phase"),
    "speed": (DYNAMICS, "groundspeed"),
    "soc": (BATTERY, "soc"), "consumed": (BATTERY, "consumed"), "energy": (BATTERY, "energy_used"),
    "missionState": (STRATEGY, "mission_state"), "targetsAssigned": (STRATEGY, "targets_assigned"),
    "targetsVisited": (STRATEGY, "targets_visited"), "photoCount": (STRATEGY, "photo_count"),
    "lastPhotoTarget": (STRATEGY, "last_photo_target"), "lastPhotoTime": (STRATEGY, "last_photo_time"),
    "lastPhotoX": (STRATEGY, "last_photo_x"), "lastPhotoY": (STRATEGY, "last_photo_y"),
}
REQUIRED_ROLES = ("x", "y", "z", "phase")
OPTIONAL_ROLES = tuple(r for r in MONITOR_CONNECTORS if r not in REQUIRED_ROLES)
PHOTO_ROLES = ("lastPhotoTarget", "lastPhotoTime", "lastPhotoX", "lastPhotoY")
#: trajectory.csv column -> the role it shows (besides x, y, z)
TRAJECTORY_ROLES = {"speed": "speed", "soc": "soc", "consumed": "consumed", "phase": "phase",
                    "mission_state": "missionState", "photo_count": "photoCount"}

# ------------------------------------------------------------------------------------- dynamics phases
AIRBORNE_PHASES = (TAKEOFF, FLY, LAND)
PHASE_LANDED = LANDED
PHASE_PREFLIGHT = PREFLIGHT
#: dynamics phase code -> the name trajectory.csv shows
PHASE_NAMES = {PREFLIGHT: "preflight", TAKEOFF: "takeoff", FLY: "fly", LAND: "land", LANDED: "landed"}

# ------------------------------------------------------------------------------------- mission states
#: strategy mission_state code -> the event name the monitor emits when the state is entered, which is also
#: the state's name in the summary and trajectory.csv.  An event says what has just happened: entering
#: RETURN_DONE ("targets done, return") starts the flight home, hence ``return_started``.
MISSION_EVENTS = {STATE_PREFLIGHT: "preflight", STATE_TAKEOFF: "takeoff", TRANSIT: "transit",
                  RETURN_DONE: "return_started", RETURN_LOW: "return_low", LAND_BASE: "landing",
                  LAND_NOW: "forced_landing", LANDED_BASE: "landed_base", LANDED_AWAY: "landed_away",
                  RETURN_CMD: "return_commanded", LAND_CMD: "landing_commanded"}
MISSION_DETAIL = {RETURN_DONE: "all targets visited, returning to base",
                  RETURN_LOW: "battery 80 % consumed: mission abandoned, returning to base",
                  LAND_BASE: "over the base, landing",
                  LAND_NOW: "battery 95 % consumed away from the base: landing where it is",
                  LANDED_BASE: "landed at the base", LANDED_AWAY: "landed away from the base",
                  RETURN_CMD: "the ground station commanded the return to base",
                  LAND_CMD: "the ground station commanded a landing where the UAV is"}
#: states after which the strategy has registered the landing for good
FINAL_STATES = (LANDED_BASE, LANDED_AWAY)
#: states that mean a landing away from the base
FORCED_LANDING_STATES = (LAND_NOW, LANDED_AWAY)
STATE_RETURN_LOW = RETURN_LOW
STATE_RETURN_CMD = RETURN_CMD

# ------------------------------------------------------------------------------------- mission outcomes
UAV_COLLISION, ZONE_COLLISION = "uav_collision", "zone_collision"
#: a UAV given no target (more UAVs than targets, or an assignment that left it out): it flies nothing worth
#: calling a success or a failure
NO_TARGETS = "no_targets"

# ------------------------------------------------------------------------------------- campaign table
#: the column naming the UAV of a row of the campaign table, and its value on the row of a run's totals
UAV_COLUMN, TOTAL_ROW = "uav", "total"
