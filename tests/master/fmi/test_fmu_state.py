"""FMU state of our pythonfmu FMUs (uavsim.fmi.StateMixin): save, step, restore, step again gives the same
outputs bit for bit, in process and through the pythonfmu binary; what the state must hold (random
generators, internal sub-steps, attributes made later) is exercised by the UAV FMUs with wind."""
from pathlib import Path

import numpy as np
import pytest

from master.execution import Execution

REPO = Path(__file__).resolve().parents[3]


def _outputs(ex, steps: int) -> list[bytes]:
    out = []
    for _ in range(steps):
        ex.step()
        out.append(b"".join(a.tobytes() for a in ex.rt.out.values()))
    return out


def _replay(scenario, before: int, steps: int, **options) -> tuple[list[bytes], list[bytes]]:
    with Execution(scenario, output=None, **options) as ex:
        ex.initialize()
        assert all(s.can_save_state for s in ex.rt.slaves)
        for _ in range(before):
            ex.step()
        state = ex.save_state()
        first = _outputs(ex, steps)
        ex.restore_state(state)
        again = _outputs(ex, steps)
        ex.release_state(state)
    return first, again


@pytest.mark.parametrize("inprocess", [True, False])
def test_uav_fmus_restore_bit_for_bit(inprocess):
    # one UAV under gusty, turbulent wind (the wind FMU draws from its generators every 1 s decision), flying:
    # 60 s in, then 30 s (300 steps of 0.1 s) twice from the saved point
    params = {"wind.probability": 0.5, "wind.turbulence": True, "wind.gusts": True}
    first, again = _replay(REPO / "ssp" / "paper_free_1uav_A.ssp", 600, 300, params=params, inprocess=inprocess)
    assert first == again
    assert len(set(first)) == len(first)        # the outputs do change from step to step


def test_restore_is_the_state_of_the_save_and_not_of_a_neighbour():
    # restoring twice from one point, with other steps between, gives the same; the wind's generator is not
    # shared with the saved copy (a shallow copy would advance both)
    with Execution(REPO / "ssp" / "paper_free_1uav_A.ssp", output=None,
                   params={"wind.probability": 0.5, "wind.turbulence": True}) as ex:
        ex.initialize()
        ex.simulate_until(20.0)
        state = ex.save_state()
        a = _outputs(ex, 50)
        ex.restore_state(state)
        _outputs(ex, 120)
        ex.restore_state(state)
        b = _outputs(ex, 50)
        ex.release_state(state)
    assert a == b


@pytest.mark.parametrize("ssp, inprocess", [("oscillator_fd_py.ssp", True), ("oscillator_fd_py.ssp", False),
                                            ("algebraic_loop_py.ssp", True)])
def test_benchmark_pythonfmus_restore_bit_for_bit(ssp, inprocess):
    first, again = _replay(REPO / "ssp" / "coupling" / ssp, 7, 40, inprocess=inprocess, record=["*"])
    assert first == again


def test_state_mixin_drops_attributes_made_after_the_save_and_copies_generators():
    import sys
    sys.path.insert(0, str(REPO / "fmu_sources"))
    from uavsim.fmi import StateMixin

    class Slave(StateMixin):
        pass

    s = Slave()
    s.vars, s.rng, s.x = {"registered": 1}, np.random.default_rng(5), [1.0, 2.0]
    saved = s._get_fmu_state()
    drawn = s.rng.random(3)
    s.x.append(3.0)
    s.late = "made after the save"
    s._set_fmu_state(saved)
    assert not hasattr(s, "late") and s.x == [1.0, 2.0] and s.vars == {"registered": 1}
    np.testing.assert_array_equal(s.rng.random(3), drawn)
    s._set_fmu_state(saved)           # a token restores any number of times
    np.testing.assert_array_equal(s.rng.random(3), drawn)
