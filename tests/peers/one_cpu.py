"""Run a peer's child process on one CPU (``COSIM_TEST_PEER_ONE_CPU=0``: on every CPU it may use).

Ecos steps the instances with ``std::execution::par`` (TBB) and libcosim with its worker pool, and our pythonfmu
FMUs serialise those threads on the GIL anyway: with a second CPU the hand-offs and TBB's spinning workers cost
more CPU than the steps (Ecos flying the whole shipped one-UAV mission: 0.7-0.8 s on one CPU, 0.7 or 4.8 s on
two, by chance), and the SITL firmware, which inherits the mask, lock-steps with its FMU on the same CPU.  The
threads are the peers' own business: every instance steps from the inputs of the step before (Jacobi), so the
frames are the same bit for bit either way (checked when written: Ecos, libcosim and OMSimulator on a SITL flight
and two four-UAV flights).  Call it before the peer's library is loaded (TBB reads the mask when it starts).
"""
from __future__ import annotations

import os


def pin() -> None:
    if os.environ.get("COSIM_TEST_PEER_ONE_CPU", "1") != "0" and hasattr(os, "sched_setaffinity"):   # Linux
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
