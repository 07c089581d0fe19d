"""What each vehicle says about itself: its telemetry messages, encoded from one read of the fleet's values.

Units and frames as MAVLink defines them (common.xml): positions in 1e-7 degrees and millimetres, NED
velocities in cm/s, headings in centidegrees, time stamps the simulated time since the start
(``time_boot_ms``).  The UAVs are point masses: the attitude shown is the course as yaw and the lean angle
of the thrust demand (``tilt``) as nose-down pitch, with no roll.
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as m

from uavsim.dynamics import FLY, LAND, LANDED, PREFLIGHT, TAKEOFF

from ..names import FINAL_STATES, FORCED_LANDING_STATES, STATE_RETURN_LOW
from .frames import Frame, packed

LANDED_STATE = {PREFLIGHT: m.MAV_LANDED_STATE_ON_GROUND, TAKEOFF: m.MAV_LANDED_STATE_TAKEOFF,
                FLY: m.MAV_LANDED_STATE_IN_AIR, LAND: m.MAV_LANDED_STATE_LANDING,
                LANDED: m.MAV_LANDED_STATE_ON_GROUND}
AIRBORNE = (TAKEOFF, FLY, LAND)
UNKNOWN_U16 = 65535
POSITION, ATTITUDE = Frame(m.MAVLink_global_position_int_message), Frame(m.MAVLink_attitude_message)
HEARTBEAT, HUD = Frame(m.MAVLink_heartbeat_message), Frame(m.MAVLink_vfr_hud_message)
SYS_STATUS, BATTERY = Frame(m.MAVLink_sys_status_message), Frame(m.MAVLink_battery_status_message)
EXT_STATE, CURRENT = Frame(m.MAVLink_extended_sys_state_message), Frame(m.MAVLink_mission_current_message)


def _i(v, default=0) -> int:
    return int(v) if v == v else default


class Telemetry:
    """Encoders (one per vehicle: its system id and sequence numbers) and the messages of one tick."""

    def __init__(self, fleet):
        self.fleet = fleet
        self.enc = [m.MAVLink(None, srcSystem=v.sysid, srcComponent=1) for v in fleet.vehicles]
        self.heading = [0.0] * len(fleet.vehicles)     # kept while a vehicle hovers (no course)

    def fast(self, t_ms: int, cols, removed) -> list[bytes]:
        """GLOBAL_POSITION_INT and ATTITUDE of every vehicle."""
        geo = self.fleet.geodetic(cols["x"], cols["y"], cols["z"])
        rel = cols["z"].tolist()
        ve, vn, vu = cols["vx"].tolist(), cols["vy"].tolist(), cols["vz"].tolist()
        tilt = cols["tilt"].tolist()
        out = []
        heading = self.heading
        atan2, degrees, radians = math.atan2, math.degrees, math.radians
        for k, enc in enumerate(self.enc):
            e, n_, u = ve[k], vn[k], vu[k]
            if removed[k] or not e == e:
                e = n_ = u = 0.0
            if e * e + n_ * n_ > 0.25:
                heading[k] = atan2(e, n_)
            hdg = heading[k]
            lat, lon, alt = geo[k]
            out.append(POSITION.pack(enc, t_ms, round(lat * 1e7), round(lon * 1e7), round(alt * 1000.0),
                                     round(rel[k] * 1000.0), round(n_ * 100), round(e * 100), round(-u * 100),
                                     round(degrees(hdg) % 360.0 * 100) % 36000))
            pitch = -radians(tilt[k]) if tilt[k] == tilt[k] and not removed[k] else 0.0
            out.append(ATTITUDE.pack(enc, t_ms, 0.0, pitch, hdg, 0.0, 0.0, 0.0))
        return out

    def slow(self, t_ms: int, cols, removed, mission_seq) -> list[bytes]:
        """HEARTBEAT, VFR_HUD, SYS_STATUS, BATTERY_STATUS, EXTENDED_SYS_STATE and MISSION_CURRENT."""
        out = []
        cap = self.fleet.capacity_ah
        for k, enc in enumerate(self.enc):
            phase, state = _i(cols["phase"][k], PREFLIGHT), _i(cols["state"][k], 0)
            armed = phase in AIRBORNE and not removed[k]
            if removed[k]:
                status = m.MAV_STATE_FLIGHT_TERMINATION
            elif state in FORCED_LANDING_STATES and state not in FINAL_STATES:
                status = m.MAV_STATE_EMERGENCY
            elif state == STATE_RETURN_LOW:
                status = m.MAV_STATE_CRITICAL
            else:
                status = m.MAV_STATE_ACTIVE if armed else m.MAV_STATE_STANDBY
            base = m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | m.MAV_MODE_FLAG_AUTO_ENABLED
            if armed:
                base |= m.MAV_MODE_FLAG_SAFETY_ARMED
            out.append(HEARTBEAT.pack(enc, m.MAV_TYPE_QUADROTOR, m.MAV_AUTOPILOT_GENERIC, base, state, status, 3))
            soc, volt, cur = cols["soc"][k], cols["voltage"][k], cols["current"][k]
            pct = max(0, min(100, int(round(soc * 100)))) if soc == soc else -1
            mv = _i(round(volt * 1000), UNKNOWN_U16) if volt == volt else UNKNOWN_U16
            ca = _i(round(cur * 100), -1) if cur == cur else -1
            gs, air, z, vz = cols["groundspeed"][k], cols["airspeed"][k], cols["z"][k], cols["vz"][k]
            hdg = int(round(math.degrees(self.heading[k]))) % 360
            out.append(HUD.pack(enc, _f(air), _f(gs), hdg, 0, _f(z), _f(vz)))
            out.append(SYS_STATUS.pack(enc, 0, 0, 0, 0, min(mv, UNKNOWN_U16), ca, pct, 0, 0, 0, 0, 0, 0))
            consumed = cols["consumed"][k]
            mah = _i(round(consumed * cap[k] * 1000), -1) if consumed == consumed else -1
            energy = cols["energy"][k]
            hj = _i(round(energy / 100.0), -1) if energy == energy else -1
            voltages = [min(mv, UNKNOWN_U16 - 1)] + [UNKNOWN_U16] * 9
            out.append(BATTERY.pack(enc, 0, m.MAV_BATTERY_FUNCTION_ALL, m.MAV_BATTERY_TYPE_LIPO, 32767, voltages, ca,
                                    mah, hj, pct))
            landed = LANDED_STATE.get(phase, m.MAV_LANDED_STATE_UNDEFINED)
            out.append(EXT_STATE.pack(enc, m.MAV_VTOL_STATE_UNDEFINED, landed))
            out.append(CURRENT.pack(enc, mission_seq[k], len(self.fleet.vehicles[k].mission)))
        return out

    def home(self, k: int, t_ms: int) -> bytes:
        v, enc = self.fleet.vehicles[k], self.enc[k]
        lat, lon, alt = v.home_geo
        return packed(enc, enc.home_position_encode(round(lat * 1e7), round(lon * 1e7), round(alt * 1000),
                                                    float(v.home[1]), float(v.home[0]), 0.0, [1.0, 0.0, 0.0, 0.0],
                                                    0.0, 0.0, 0.0, t_ms * 1000))

    def text(self, k: int, severity: int, text: str) -> bytes:
        return statustext(self.enc[k], severity, text)

    def reached(self, k: int, seq: int) -> bytes:
        enc = self.enc[k]
        return packed(enc, enc.mission_item_reached_encode(seq))


def _f(v) -> float:
    return float(v) if v == v else 0.0


def statustext(enc, severity: int, text: str) -> bytes:
    """A STATUSTEXT from ``enc``'s system and component (50 characters at most, as the message holds)."""
    return packed(enc, enc.statustext_encode(severity, text[:50].encode("ascii", "replace")))
