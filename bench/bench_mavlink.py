"""What streaming the fleet to a ground station costs (``--mavlink``, uavstudy/mavlink).

Usage: python bench/bench_mavlink.py [--repeats 3] [--fleets 16,64,128,254] [--fleet-sim 60] [--check-sim 30]

1. Slowdown: the shipped 4-UAV mission with zones (ssp/paper_zones_4uav_B.ssp, 461.5 s simulated, step
   0.1 s), unpaced, run in process by ``master.runner.run`` with and without ``--mavlink`` (udpout to a
   listening UDP socket that nobody reads, 10 Hz positions), best of ``--repeats``, interleaved: the whole
   run's wall time, and of the step loop alone (``Execution.simulate_until``) the wall time, the CPU time of
   the simulation's process and that of the streaming process.  On a loaded machine the wall times are
   noise; the CPU times say what the stream costs the simulation.
2. Fleet: for each fleet size, the scaling study's scenario (bench/bench_uav_scaling.py ``make_scenario``,
   step 0.1 s, its targets cut to the strategy FMU's 64) streamed at 10 Hz without pacing for ``--fleet-sim`` simulated seconds: real-time factor of
   the step loop (the ``Execution`` stepping timed alone) = simulated s / wall s.  A fleet streams in real time
   when that factor is above 1; the largest such fleet is then run paced (``--realtime 1``) for
   ``--check-sim`` s and run.json's pacing facts (steps behind the wall clock, largest lag) are shown.
   MAVLink addresses at most 254 vehicles on one network (system ids 1-254, 255 is the ground station's), so
   254 is the largest fleet a stream can carry.
"""
from __future__ import annotations

import argparse
import os
import resource
import socket
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from master.execution import Execution  # noqa: E402
from master.runner import run  # noqa: E402

SSP = ROOT / "ssp" / "paper_zones_4uav_B.ssp"


def sink():
    """A UDP port that takes the datagrams (as a ground station's would) and is never read."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    return s, f"udpout:127.0.0.1:{s.getsockname()[1]}"


def timed_loop(ssp, out, **options) -> tuple[float, dict]:
    """Wall time of the step loop alone (initialize and close excluded) and the run's metadata, with the CPU
    time of the loop in this process (``cpu``) and of the streaming process (``stream_cpu``)."""
    ex = Execution(ssp, output=out, **options)
    ex.initialize()
    c0 = time.process_time()
    k0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    ex.simulate_until()
    loop = time.perf_counter() - t0
    cpu = time.process_time() - c0
    ex.close("completed")
    k1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    ex.metadata["cpu"] = cpu
    ex.metadata["stream_cpu"] = (k1.ru_utime + k1.ru_stime) - (k0.ru_utime + k0.ru_stime)
    return loop, ex.metadata


def slowdown(tmp: Path, repeats: int) -> list[tuple]:
    rows = []
    s, url = sink()
    try:
        best = {}
        for r in range(repeats):          # interleaved, so that a change of the machine's load hits both
            for label, extra in (("plain", {}), ("--mavlink", {"mavlink": [url]})):
                t0 = time.perf_counter()
                run(SSP, output=tmp / f"slow_{label.strip('-')}_{r}", **extra)
                wall = time.perf_counter() - t0
                loop, meta = timed_loop(SSP, tmp / f"loop_{label.strip('-')}_{r}", **extra)
                b = best.setdefault(label, [wall, loop, meta["cpu"], meta["stream_cpu"], meta])
                b[:4] = [min(b[0], wall), min(b[1], loop), min(b[2], meta["cpu"]), min(b[3], meta["stream_cpu"])]
        for label, (wall, loop, cpu, scpu, meta) in best.items():
            rows.append((label, meta["steps_done"], wall, loop, cpu, scpu,
                         meta.get("observers", {}).get("mavlink", {}).get("messages_sent", 0)))
    finally:
        s.close()
    return rows


def fleet_scenario(n: int, sim: float):
    """The scaling study's scenario for n UAVs, its targets cut to what the strategy FMU takes (64): in a
    large fleet most UAVs then take off and land again, which streams like any other flight."""
    import dataclasses

    from bench_uav_scaling import make_scenario
    from uavsim.mission_encoding import MAX_TARGETS
    scn = make_scenario(n, step=0.1, stop_time=sim)
    return dataclasses.replace(scn, targets=scn.targets[:MAX_TARGETS])


def fleet(tmp: Path, sizes: list[int], sim: float, check: float) -> tuple[list[tuple], tuple | None]:
    from uavstudy.build import build_ssp
    rows = []
    s, url = sink()
    try:
        for n in sizes:
            ssp = build_ssp(fleet_scenario(n, sim), tmp / f"fleet{n}.ssp")
            loop, meta = timed_loop(ssp, tmp / f"fleet{n}", mavlink=[url], write_csv=False)
            sent = meta["observers"]["mavlink"]["messages_sent"]
            rows.append((n, meta["steps_done"], sim, loop, sim / loop, sent / loop, meta["cpu"], meta["stream_cpu"],
                         meta["observers"]["mavlink"].get("ticks_dropped", 0)))
        fits = [r for r in rows if r[4] > 1.0]
        paced = None
        if fits and check > 0:
            n = max(r[0] for r in fits)
            ssp = build_ssp(fleet_scenario(n, check), tmp / f"paced{n}.ssp")
            loop, meta = timed_loop(ssp, tmp / f"paced{n}", mavlink=[url], realtime=1.0, write_csv=False)
            p = meta["observers"]["pacing"]
            paced = (n, check, loop, p["steps_behind"], meta["steps_done"], p["max_lag_s"])
    finally:
        s.close()
    return rows, paced


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--fleets", default="16,64,128,254")
    ap.add_argument("--fleet-sim", type=float, default=60.0)
    ap.add_argument("--check-sim", type=float, default=30.0)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bench_mavlink_") as tmp:
        tmp = Path(tmp)
        rows = slowdown(tmp, args.repeats)
        print("4-UAV mission with zones (paper_zones_4uav_B.ssp), unpaced, best of", args.repeats)
        print(f"{'run':<12}{'steps':>7}{'run wall s':>12}{'loop wall s':>13}{'loop CPU s':>12}{'stream CPU s':>14}"
              f"{'messages':>10}{'wall +':>9}{'CPU +':>8}")
        base_loop, base_cpu = rows[0][3], rows[0][4]
        for label, steps, wall, loop, cpu, scpu, sent in rows:
            print(f"{label:<12}{steps:>7}{wall:>12.2f}{loop:>13.2f}{cpu:>12.2f}{scpu:>14.2f}{sent:>10}"
                  f"{100 * (loop / base_loop - 1):>8.1f}%{100 * (cpu / base_cpu - 1):>7.1f}%")
        print("(loop CPU: the simulation's process; stream CPU: the streaming process, on another core if free)")
        sizes = [int(x) for x in args.fleets.split(",") if x.strip()]
        frows, paced = fleet(tmp, sizes, args.fleet_sim, args.check_sim)
        print(f"\nfleets streamed at 10 Hz, unpaced, {args.fleet_sim:g} s simulated, step 0.1 s")
        print(f"{'UAVs':>5}{'steps':>7}{'loop s':>9}{'RTF':>8}{'msg/s':>10}{'loop CPU s':>12}{'stream CPU s':>14}"
              f"{'ticks dropped':>15}  real time?")
        for n, steps, sim, loop, rtf, rate, cpu, scpu, dropped in frows:
            print(f"{n:>5}{steps:>7}{loop:>9.2f}{rtf:>8.2f}{rate:>10.0f}{cpu:>12.2f}{scpu:>14.2f}{dropped:>15}  "
                  f"{'yes' if rtf > 1 else 'no'}")
        if paced:
            n, sim, loop, behind, steps, lag = paced
            print(f"\npaced check: {n} UAVs, --realtime 1, {sim:g} s simulated in {loop:.2f} s wall; "
                  f"{behind}/{steps} steps behind the wall clock, largest lag {lag:.3f} s")
    print(f"(python {sys.version.split()[0]}, {os.cpu_count()} CPUs, load average "
          f"{' '.join(f'{x:.1f}' for x in os.getloadavg())})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
