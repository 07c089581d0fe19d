"""Pacing (``--realtime``): the run waits for the wall clock, never hurries, and says how far behind it fell."""
from master.observers.pacing import Pacer


class FakeClock:
    def __init__(self):
        self.now = 100.0
        self.slept = []

    def __call__(self):
        return self.now

    def sleep(self, s):
        self.slept.append(s)
        self.now += s


def test_sleeps_until_the_wall_clock_reaches_simulated_time_over_the_factor():
    clock = FakeClock()
    pacer = Pacer(10.0, clock=clock, sleep=clock.sleep)
    pacer.attach(None, 2.0)                     # simulated start 2 s
    clock.now += 0.003                          # the step took 3 ms of wall time
    pacer.after_step(0, 2.0, 2.1)               # 0.1 s simulated at 10x = 10 ms of wall time after the start
    assert abs(clock.slept[-1] - 0.007) < 1e-12
    clock.now += 0.030                          # a slow step: 30 ms for 10 ms of pace
    pacer.after_step(1, 2.1, 2.2)
    assert len(clock.slept) == 1                # behind: no sleep, no hurry
    info = pacer.finish(None, "completed")
    assert info["steps_behind"] == 1 and abs(info["max_lag_s"] - 0.020) < 1e-9
    clock.now += 0.001
    pacer.after_step(2, 2.2, 2.4)               # ends at 40 ms after start; the clock is at 41 ms
    assert len(clock.slept) == 1
