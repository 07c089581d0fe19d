"""The paper's published numbers (section V), each with the sentence it is quoted from, the tolerance we accept
around our interval where the paper gives a value, and what its numbers imply about each other.

Everything here comes from the paper alone: no campaign data is read.
"""
from __future__ import annotations

__all__ = ["PAPER", "PAPER_VALUES", "PAPER_MISSIONS", "PAPER_REPETITIONS", "paper_consistency"]

#: the published numbers, quoted from the paper (section V)
PAPER = {
    "runs": ("336", "\"... for each possibility of wind occurrence, three simulations were performed, which "
                    "resulted in a total of 336 simulations.\""),
    "max_success": ("42, 84, 126, 168", "\"The maximum number of successes that could be obtained for the strategy "
                                        "simulations with 1, 2, 3 and 4 UAVs, respectively, were 42, 84, 126, 168.\""),
    "success_1": ("0 (A), 0 (B)", "\"It can be noted that using only 1 UAV was unsuccessful ...\""),
    "success_2": ("0 (A), > 0 (B)", "\"... and with 2 UAVs only success by strategy B.\""),
    "success_dir": ("B > A", "\"... it can be noted that strategy B was superior to strategy A.\""),
    "battery_total": ("41.07 % (A), 41.83 % (B)", "\"... the total remaining battery of the drones that used "
                                                  "Strategy B was 41.83%, against 41.07% of Strategy A.\""),
    "battery_area": ("A > B in both areas", "\"It can be observed that Strategy A, characterized by the blue color, "
                                            "was superior to Strategy B.\" (Fig. 6)"),
    "battery_wind": ("decreases with wind", "\"... the consumption increases with higher probabilities of wind "
                                            "because the drones correct their trajectories ...\" (Fig. 7)"),
    "battery_zones": ("zones > free", "\"Low battery consumption in restricted areas is justified by the high rate "
                                      "of collisions in these areas ...\""),
    "distance_total": ("~270 km (A), ~240 km (B)", "\"Strategy B was superior in this metric, with a total distance "
                                                   "traveled was about 240km. Strategy A was about 270km ...\""),
    "distance_zones": ("zones < free", "\"... in restricted areas, the distances traveled are smaller.\""),
    "distance_wind": ("increases with wind", "\"... with some exceptions, the higher the occurrence of wind, the "
                                             "greater its influence on the total distance of the flight course.\""),
    "collisions": ("215 (A), 181 (B)", "\"For this metric, Strategy A had 215 total collisions, while in Strategy B, "
                                       "there were 181.\""),
    "wall_ratio": ("zone ≈ 3 × UAV, both strategies", "\"... in the two strategies, the number of collisions occurred "
                                                      "in the wall is the triple of those between UAVs.\""),
    "battery_fleet": ("increases with fleet size, except A with 1 UAV",
                      "\"... the average of the remaining battery charge per quantity of UAVs tends to gradually "
                      "increase ... a notable exception ... Strategy A, when only one UAV was used.\" (Fig. 10)"),
    "table2": ("B better on all 8 metrics", "Table II marks Strategy A with x on every row and Strategy B with a "
                                            "check (the extracted text shows the symbols as •, ✓, /)."),
}
#: the paper's numbers that are values (not only directions): (value, tolerance, unit) -- the tolerance is
#: what we accept around our 95 % interval (fixed before the data): 2 battery points (the paper gives two
#: decimals but not its energy law), 10 % of a distance or a count (our layout is assumed), 0 for its zero
#: success counts, 1 around its "triple"
PAPER_VALUES = {
    "battery_A": (41.07, 2.0, "%"), "battery_B": (41.83, 2.0, "%"),
    "distance_A": (270.0, 27.0, "km"), "distance_B": (240.0, 24.0, "km"),
    "collisions_A": (215.0, 21.5, "UAVs"), "collisions_B": (181.0, 18.1, "UAVs"),
    "success_1_A": (0.0, 0.0, "missions"), "success_1_B": (0.0, 0.0, "missions"), "success_2_A": (0.0, 0.0, "missions"),
    "wall_ratio": (3.0, 1.0, "x"),
}
#: UAV missions per strategy in the paper's grid: (1 + 2 + 3 + 4) UAVs x 2 areas x 7 wind levels x 3 repetitions
PAPER_MISSIONS = 420
#: the paper's repetitions of each grid point ("three simulations were performed"): its totals are over 3 of our
#: layouts' worth of runs
PAPER_REPETITIONS = 3


def paper_consistency() -> list[str]:
    """Which of the paper's numbers cannot all hold together, computed from the numbers themselves."""
    out = []
    for strategy, km, battery_left, collisions in (("A", 270.0, 41.07, 215), ("B", 240.0, 41.83, 181)):
        used = 100.0 - battery_left
        km_per_mission = km / PAPER_MISSIONS
        collided = collisions / PAPER_MISSIONS
        # a surviving mission can use at most 95 % (forced landing): the collided ones must have used the rest
        collided_min_used = (used - (1 - collided) * 95.0) / collided
        out.append(f"Strategy {strategy}: {km:.0f} km over {PAPER_MISSIONS} missions is {km_per_mission:.3f} km "
                   f"per mission, yet {used:.2f} % of the battery was used on average: a whole battery would last "
                   f"{km_per_mission / used * 100:.2f} km ({km_per_mission / used * 100 / 5.0 * 1000 / 60:.1f} min "
                   f"at 5 m/s), and the 80 % return would come after {km_per_mission / used * 80:.2f} km. With "
                   f"{collisions} of {PAPER_MISSIONS} missions ({collided * 100:.0f} %) "
                   f"ended by a collision (more if a UAV-UAV collision, which ends two missions, counts once) and "
                   f"no mission using more than 95 %, the collided missions must have used at least "
                   f"{collided_min_used:.1f} % each on average, which contradicts the paper's \"collisions at the "
                   f"beginning of the simulation\" (Fig. 6 text).")
    out.append("Fig. 6 says strategy A kept more battery than B in both areas, while the totals say B kept more "
               "(41.83 % against 41.07 %). Both strategies fly 210 missions in each area, so each overall mean is "
               "the average of its two area means: A ahead in both areas forces A ahead overall. The two cannot "
               "both hold.")
    out.append("215 and 181 collisions are not multiples of 4, so the wall collisions cannot be exactly three times "
               "the UAV collisions (z = 3u gives z + u = 4u); \"the triple\" can only be approximate "
               "(215 = 161 + 54: 2.98x; 181 = 136 + 45: 3.02x).")
    return out
