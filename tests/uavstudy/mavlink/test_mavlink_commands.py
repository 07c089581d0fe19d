"""Ground-station commands in the strategy (uavsim.strategy.Strategy.command, the FMU's ``command`` input):
the mission logic stays the strategy's; expectations from its documented states (module docstring)."""
from uavsim.strategy import (COMMAND_LAND, COMMAND_RETURN, LAND_BASE, LAND_CMD, LANDED_AWAY, LANDED_BASE,
                             PREFLIGHT, RETURN_CMD, TRANSIT, Strategy, StrategyParams)

TARGETS = "200,0;300,0"          # ENU m, base at (0, 0)


def flying():
    s = Strategy(StrategyParams(targets=TARGETS, cruise_altitude=20.0))
    s.step(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1, 0.1)          # taking off
    s.step(1.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1)         # at altitude: first leg
    assert s.state == TRANSIT and s.current_target == 0
    return s


def test_return_command_sends_the_uav_home_and_it_lands_at_the_base():
    s = flying()
    assert s.command(COMMAND_RETURN, 80.0, 0.0, 20.0)
    s.step(2.0, 80.0, 0.0, 20.0, 5.0, 0.0, 2, 0.2)
    assert s.state == RETURN_CMD and s.current_target == -1
    assert s.cmd == 2 and s.sp == (0.0, 0.0, 20.0)          # to the base, at cruise altitude
    s.step(3.0, 0.5, 0.0, 20.0, 0.0, 0.0, 2, 0.3)          # over the base (within the arrival radius)
    assert s.state == LAND_BASE and s.cmd == 3
    s.step(4.0, 0.5, 0.0, 0.0, 0.0, 0.0, 4, 0.3)
    assert s.state == LANDED_BASE and s.targets_visited == 0


def test_land_command_lands_where_the_uav_is():
    s = flying()
    assert s.command(COMMAND_LAND, 80.0, 10.0, 20.0)
    s.step(2.0, 80.0, 10.0, 20.0, 0.0, 0.0, 2, 0.2)
    assert s.state == LAND_CMD and s.cmd == 3 and s.sp == (80.0, 10.0, 20.0)
    s.step(3.0, 80.0, 10.0, 0.0, 0.0, 0.0, 4, 0.2)
    assert s.state == LANDED_AWAY


def test_commands_outside_flight_are_ignored():
    s = Strategy(StrategyParams(targets=TARGETS))
    assert not s.command(COMMAND_RETURN, 0.0, 0.0, 0.0) and s.state == PREFLIGHT
    assert not s.command(COMMAND_LAND, 0.0, 0.0, 0.0) and s.state == PREFLIGHT
    s = flying()
    s.command(COMMAND_LAND, 80.0, 0.0, 20.0)
    assert not s.command(COMMAND_RETURN, 80.0, 0.0, 20.0) and s.state == LAND_CMD    # a landing is final
