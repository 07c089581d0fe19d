"""Default parameters of the UAV models (3DR Iris+-class quadcopter), each with its source.

Units are SI unless the name says otherwise.  Every FMU parameter of the UAV FMUs takes its
default from here; docs/uav_models.md lists them with the same sources.

Sources (short keys used in the comments below):

* [IRIS]   3DR IRIS+ specification sheet / operation manual (3D Robotics, 2014): weight with
           battery 1282 g, payload capacity 400 g, 3S 11.1 V 5100 mAh LiPo, 10 x 4.7 in propellers,
           950 kV motors, "flight time 16-22 minutes".
* [APWP]   ArduPilot Copter parameter documentation / AC_WPNav.cpp defaults (Copter 4.x):
           WPNAV_SPEED 1000 cm/s, WPNAV_SPEED_UP 250 cm/s, WPNAV_SPEED_DN 150 cm/s,
           WPNAV_ACCEL 250 cm/s/s, WPNAV_ACCEL_Z 100 cm/s/s, WPNAV_RADIUS 200 cm.
* [APLAND] ArduPilot Copter LAND_SPEED 50 cm/s (final descent), LAND_ALT_LOW 1000 cm (altitude
           below which LAND_SPEED applies; above it WPNAV_SPEED_DN is used).
* [APATC]  ArduPilot Copter ANGLE_MAX 3000 cdeg (30 deg lean-angle limit), PSC_POSXY_P 1.0,
           PSC_VELXY_P 2.0, PSC_VELXY_I 1.0, PSC_POSZ_P 1.0.
* [ZENG]   Y. Zeng, J. Xu, R. Zhang, "Energy minimization for wireless communication with
           rotary-wing UAV", IEEE Trans. Wireless Commun. 18(4):2329-2345, 2019, eq. (12) and
           Table I (delta = 0.012, k = 0.1, rho = 1.225 kg/m^3).
* [MIL]    MIL-F-8785C (1980) sec. 3.7 / MIL-HDBK-1797 (1997): Dryden low-altitude turbulence,
           sigma_w = 0.1 W20, L_w = h, L_u = L_v = h / (0.177 + 0.000823 h)^1.2 (h in ft),
           discrete "1-cosine" gust.
* [BFT]    Beaufort wind scale (WMO): force 3 gentle breeze 3.4-5.4 m/s, force 4 moderate breeze
           5.5-7.9 m/s, force 6 strong breeze 10.8-13.8 m/s.
* [PAPER]  the reproduced paper (shared/paper.txt): 80 % / 95 % battery rules, 2 m look-ahead,
           wind pushing from east to west with weak/moderate/strong intensity.
* [ASSUME] modelling assumption of this project, documented in docs/uav_models.md.
"""
from __future__ import annotations

import math

G0 = 9.80665                # m/s^2 standard gravity (ISO 80000-3)
RHO_SL = 1.225              # kg/m^3 ISA sea-level air density [ZENG Table I]

# ---------------------------------------------------------------- airframe
MASS = 1.5                  # kg: 1.282 kg Iris+ with battery [IRIS] + ~0.22 kg camera/gimbal
                            #     payload for the photo mission (within the 400 g payload) [ASSUME]
FLAT_PLATE_AREA = 0.05      # m^2 equivalent flat-plate drag area S_FP = Cd*A of the airframe;
                            #     gives ~2.0 N drag at 10 m/s, max holdable wind ~16.6 m/s [ASSUME]
MAX_TILT_DEG = 30.0         # deg lean-angle limit, ANGLE_MAX = 3000 cdeg [APATC]

# ---------------------------------------------------------------- navigation
WP_SPEED = 10.0             # m/s horizontal waypoint speed, WPNAV_SPEED = 1000 cm/s [APWP]
WP_ACCEL = 2.5              # m/s^2 horizontal acceleration, WPNAV_ACCEL = 250 cm/s/s [APWP]
SPEED_UP = 2.5              # m/s climb rate, WPNAV_SPEED_UP = 250 cm/s [APWP]
SPEED_DN = 1.5              # m/s descent rate, WPNAV_SPEED_DN = 150 cm/s [APWP]
ACCEL_Z = 1.0               # m/s^2 vertical acceleration, WPNAV_ACCEL_Z = 100 cm/s/s [APWP]
LAND_SPEED = 0.5            # m/s final descent rate, LAND_SPEED = 50 cm/s [APLAND]
LAND_ALT_LOW = 10.0         # m altitude below which LAND_SPEED is used, LAND_ALT_LOW = 1000 cm [APLAND]
POS_XY_P = 1.0              # 1/s horizontal position gain, PSC_POSXY_P [APATC]
POS_Z_P = 1.0               # 1/s vertical position gain, PSC_POSZ_P [APATC]
VEL_XY_P = 2.0              # 1/s velocity-loop P gain, PSC_VELXY_P [APATC]
VEL_XY_I = 1.0              # 1/s^2 velocity-loop I gain, PSC_VELXY_I [APATC]
PREFLIGHT_TIME = 5.0        # s pre-arm/pre-flight check duration ("a few seconds") [PAPER][ASSUME]
TAKEOFF_ALTITUDE = 20.0     # m takeoff / cruise altitude above the base [ASSUME]
SUBSTEP = 0.01              # s internal fixed integration sub-step (400 Hz loop in ArduPilot; 100 Hz
                            #   suffices for the 1-2 s time constants modelled here) [ASSUME]

# ---------------------------------------------------------------- rotor / power model [ZENG]
ROTOR_COUNT = 4
ROTOR_RADIUS = 0.127        # m: 10 in propeller [IRIS]
BLADE_COUNT = 2
BLADE_CHORD = 0.020         # m mean chord of a 10x4.7 propeller [ASSUME]
ROTOR_SOLIDITY = BLADE_COUNT * BLADE_CHORD / (math.pi * ROTOR_RADIUS)   # s = 0.100
TIP_SPEED = 86.4            # m/s: ~6500 rpm hover of 950 kV motors on 3S -> Omega R [IRIS][ASSUME]
PROFILE_DRAG_COEF = 0.012   # delta, blade profile drag coefficient [ZENG Table I]
INDUCED_CORRECTION = 0.1    # k, incremental induced-power correction [ZENG Table I]
PROPULSION_EFFICIENCY = 0.60  # shaft-to-electrical (motor x ESC) efficiency; calibrates hover
                            #   electrical power to ~190 W, i.e. ~7.8 g/W for 10 in props [ASSUME]
AVIONICS_POWER = 5.0        # W flight controller, GPS, telemetry radio, camera [ASSUME]

# ---------------------------------------------------------------- battery
CELLS = 3                   # 3S LiPo [IRIS]
CAPACITY_AH = 5.1           # Ah, 5100 mAh [IRIS]
CELL_RESISTANCE = 0.008     # ohm internal resistance per cell (fresh 5 Ah 10C LiPo) [ASSUME]
# per-cell open-circuit (resting) voltage vs state of charge: typical LiPo resting-voltage chart
# (used in RC practice; consistent with manufacturers' 0.2C discharge curves) [ASSUME]
OCV_SOC = (0.00, 0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.35, 0.40, 0.45, 0.50,
           0.55, 0.60, 0.65, 0.70, 0.75, 0.80, 0.85, 0.90, 0.95, 1.00)
OCV_CELL = (3.27, 3.61, 3.69, 3.71, 3.73, 3.75, 3.77, 3.79, 3.80, 3.82, 3.84,
            3.85, 3.87, 3.91, 3.95, 3.98, 4.02, 4.08, 4.11, 4.15, 4.20)
BATTERY_SUBSTEP = 0.05      # s coulomb-counting sub-step (divides every master step 0.05-1 s) [ASSUME]

# ---------------------------------------------------------------- wind [PAPER][BFT]
WIND_DECISION_INTERVAL = 10.0   # s: the paper draws wind before each move command [PAPER][ASSUME]
WIND_PROBABILITY = 0.0          # probability of wind per decision interval (paper: 0 ... 0.15)
WIND_SPEED_WEAK = 4.0           # m/s Beaufort 3 gentle breeze 3.4-5.4 m/s [BFT]
WIND_SPEED_MODERATE = 7.0       # m/s Beaufort 4 moderate breeze 5.5-7.9 m/s [BFT]
WIND_SPEED_STRONG = 11.0        # m/s Beaufort 6 strong breeze 10.8-13.8 m/s [BFT]
WIND_P_WEAK = 1.0 / 3.0         # intensity probabilities given wind occurs: uniform [ASSUME]
WIND_P_MODERATE = 1.0 / 3.0
WIND_DURATION = 10.0            # s duration of a wind episode (= decision interval) [ASSUME]
WIND_RAMP = 1.0                 # s onset/decay ramp of an episode [ASSUME]
WIND_DIRECTION_DEG = 90.0       # deg meteorological "from" direction: 90 = from the east, blowing
                                #   toward the west (pushes UAVs east -> west) [PAPER]
TURB_DT = 0.1                   # s Dryden noise sample interval [ASSUME]
TURB_ALTITUDE = 20.0            # m altitude used for the Dryden scales [ASSUME]
GUST_AMPLITUDE = 0.5            # discrete gust amplitude as a fraction of the episode speed [ASSUME]
GUST_LENGTH = 2.0               # s duration of the 1-cosine gust [ASSUME]

# ---------------------------------------------------------------- strategy [PAPER][APWP]
RETURN_THRESHOLD = 0.80         # consumed fraction triggering return to base [PAPER]
LAND_THRESHOLD = 0.95           # consumed fraction triggering immediate landing [PAPER]
LOOKAHEAD = 2.0                 # m restricted-zone look-ahead distance [PAPER]
ARRIVAL_RADIUS = 2.0            # m target/waypoint acceptance radius, WPNAV_RADIUS = 200 cm [APWP]
AVOID_MARGIN = 3.0              # m outward offset of detour vertices around a zone [ASSUME]
CRUISE_ALTITUDE = TAKEOFF_ALTITUDE
PLAN_MARGIN = WP_SPEED ** 2 / (2.0 * WP_ACCEL)  # m = 20 m: clearance of planned legs from the zones,
                                #   the braking distance at cruise speed [APWP][ASSUME]
LANE_SPACING = 5.0              # m extra clearance per UAV index: UAV i plans at PLAN_MARGIN + i x 5 m
                                #   (> 2 x the 2.6 m impact diameter), so detours of different UAVs
                                #   around one zone use distinct corner waypoints [ASSUME]
