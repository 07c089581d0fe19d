"""peer_runs.shared_flights: which jobs of a peer's child are served from a longer flight (no peer is run here)."""
from __future__ import annotations

from peer_runs import Job, shared_flights

SSP = "ssp/paper_zones_4uav_B.ssp"
X, Y, PHASE = ["uav1_dyn", "x", "Real"], ["uav1_dyn", "y", "Real"], ["uav1_dyn", "phase", "Integer"]


def test_a_window_rides_in_the_longest_flight_of_the_same_ssp_and_step_recording_every_variable():
    jobs = [Job(SSP, 0.1, 200, [X, PHASE]), Job(SSP, 0.1, 1500, [Y]), Job(SSP, 0.1, 700, [X])]
    for peer in ("ecos", "libcosim"):
        runs, where = shared_flights(peer, jobs)
        assert where == [0, 0, 0] and len(runs) == 1
        assert runs[0].n_steps == 1500 and runs[0].variables == [X, PHASE, Y]
    assert jobs[0].n_steps == 200 and jobs[0].variables == [X, PHASE]          # the jobs themselves untouched


def test_what_a_flight_depends_on_keeps_runs_apart():
    ecos_set = {"parameter_set": "scenario"}
    jobs = [Job(SSP, 0.1, 200, [X], options=ecos_set), Job(SSP, 0.5, 200, [X], options=ecos_set),
            Job("ssp/paper_zones_4uav_A.ssp", 0.1, 200, [X], options=ecos_set),
            Job(SSP, 0.1, 300, [X], options={"parameter_set": "other"}),
            Job(SSP, 0.1, 400, [["uav1_dyn", "x", "Integer"]], options=ecos_set)]      # read as another type
    assert shared_flights("ecos", jobs)[1] == [0, 1, 2, 3, 4]
    # libcosim applies no named parameter set: only the step, the SSP and the types tell its flights apart
    assert shared_flights("libcosim", jobs)[1] == [0, 1, 2, 0, 3]


def test_omsimulator_is_told_the_stop_time_and_runs_every_job():
    jobs = [Job(SSP, 0.1, 200, [X], set_strings=True), Job(SSP, 0.1, 8251, [X], set_strings=True)]
    runs, where = shared_flights("omsimulator", jobs)
    assert where == [0, 1] and [r.n_steps for r in runs] == [200, 8251]
