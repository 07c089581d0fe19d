"""One co-simulation master on the chain, in this process: ``python peers.py PEER ARGS_JSON``.

run_bench.py starts one subprocess per (peer, flavour, repeat) so that a crash, a leaked thread pool or
the GIL of one master cannot touch another, and so that a peer can be pinned with ``taskset``. The
subprocess prints one line ``CHAIN-RESULT {json}`` on stdout:

    ok            bool; False with "error" (one line) if the peer could not be loaded or run
    stepping_s    wall time of the timed stepping phase (time.perf_counter)
    steps_timed   how many master steps that phase covers (each one steps every FMU once)
    timing        how the stepping phase was isolated from start-up
    total_s       wall time of the whole run in this process (load + init + stepping + teardown)
    samples       {k: y of the last FMU after k steps} for k = every, 2*every, ..., steps (some peers add k=0)
    extra         peer-specific facts (versions, metadata, cross-checks)

ARGS_JSON: {"ssp", "fmu", "n", "steps", "step", "every", "last": "lag{n-1}"} plus peer options.
"""
from __future__ import annotations

import ctypes
import json
import os
import sys
import tempfile
import time
import traceback
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
perf = time.perf_counter


# ---------------------------------------------------------------------------------------------------
# (b) the floor: a bare loop of raw ctypes calls into the FMUs' shared library


class _Callbacks(ctypes.Structure):
    _fields_ = [("logger", ctypes.c_void_p), ("allocateMemory", ctypes.c_void_p), ("freeMemory", ctypes.c_void_p),
                ("stepFinished", ctypes.c_void_p), ("componentEnvironment", ctypes.c_void_p)]


_LOGGER_T = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p)


@_LOGGER_T
def _logger(env, instance, status, category, message):
    if status > 1:
        sys.stderr.write(f"[{(instance or b'').decode()}] status {status}: {(message or b'').decode()}\n")


def peer_bare_ctypes(a: dict) -> dict:
    """fmi2Instantiate/setup/init through ctypes.CDLL, then per step and FMU: fmi2SetReal (1 value),
    fmi2DoStep, fmi2GetReal (1 value). Jacobi with one buffer: the FMUs are visited from the last to the
    first, so FMU i reads y[i-1] before FMU i-1 overwrites it in this step."""
    from xml.etree import ElementTree as ET

    t_all = perf()
    n, steps, h, every = a["n"], a["steps"], a["step"], a["every"]
    tmp = tempfile.mkdtemp(prefix="chain_bare_")
    with zipfile.ZipFile(a["fmu"]) as zf:
        zf.extractall(tmp)
    md = ET.parse(os.path.join(tmp, "modelDescription.xml")).getroot()
    guid = md.get("guid").encode()
    ident = md.find("CoSimulation").get("modelIdentifier")
    vr = {v.get("name"): int(v.get("valueReference")) for v in md.find("ModelVariables")}
    # CDLL releases the GIL around every call (what fmpy, and so cosim-master, use); PyDLL keeps it
    loader = {"CDLL": ctypes.CDLL, "PyDLL": ctypes.PyDLL}[a.get("dll", "CDLL")]
    lib = loader(os.path.join(tmp, "binaries", "linux64", ident + ".so"))
    libc = ctypes.CDLL(None)
    cb = _Callbacks(ctypes.cast(_logger, ctypes.c_void_p), ctypes.cast(libc.calloc, ctypes.c_void_p),
                    ctypes.cast(libc.free, ctypes.c_void_p), None, None)
    resources = Path(tmp, "resources").as_uri().encode()

    inst = lib.fmi2Instantiate
    inst.restype = ctypes.c_void_p
    inst.argtypes = [ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p, ctypes.POINTER(_Callbacks),
                     ctypes.c_int, ctypes.c_int]
    comps = []
    for i in range(n):
        c = inst(f"lag{i}".encode(), 1, guid, resources, ctypes.byref(cb), 0, 0)
        if not c:
            raise RuntimeError(f"fmi2Instantiate failed for lag{i}")
        comps.append(ctypes.c_void_p(c))
    D = ctypes.c_double
    for c in comps:
        if lib.fmi2SetupExperiment(c, 0, D(0.0), D(0.0), 1, D(steps * h)):
            raise RuntimeError("fmi2SetupExperiment failed")
        if lib.fmi2EnterInitializationMode(c) or lib.fmi2ExitInitializationMode(c):
            raise RuntimeError("initialization failed")

    # buffers: y[0..n-1] and one cell holding lag0's unconnected input (its start value 0)
    buf = (D * (n + 1))()
    base = ctypes.addressof(buf)
    cell = [ctypes.cast(base + 8 * j, ctypes.POINTER(D)) for j in range(n + 1)]
    zero_u = cell[n]
    one = ctypes.c_size_t(1)
    vr_u = ctypes.pointer(ctypes.c_uint(vr["u"]))
    vr_y = ctypes.pointer(ctypes.c_uint(vr["y"]))
    setr, dostep, getr = lib.fmi2SetReal, lib.fmi2DoStep, lib.fmi2GetReal
    for i, c in enumerate(comps):  # initial outputs (Jacobi: step 0 uses the outputs after initialization)
        if getr(c, vr_y, one, cell[i]):
            raise RuntimeError("fmi2GetReal failed")
    plan = [(comps[i], cell[i - 1] if i else zero_u, cell[i]) for i in reversed(range(n))]
    hh = D(h)
    samples = {0: buf[n - 1]}

    t0 = perf()
    k = 0
    while k < steps:
        chunk = min(every, steps - k)
        for k in range(k, k + chunk):
            t = D(k * h)
            for c, pin, pout in plan:
                if setr(c, vr_u, one, pin) or dostep(c, t, hh, 1) or getr(c, vr_y, one, pout):
                    raise RuntimeError(f"FMI call failed at step {k}")
        k += 1
        samples[k] = buf[n - 1]
    t1 = perf()

    for c in comps:
        lib.fmi2Terminate(c)
        lib.fmi2FreeInstance(c)
    return {"stepping_s": t1 - t0, "steps_timed": steps, "timing": "perf_counter around the step loop only",
            "total_s": perf() - t_all, "samples": samples, "extra": {"loader": loader.__name__}}


# ---------------------------------------------------------------------------------------------------
# (a) cosim-master


def peer_cosim_master(a: dict) -> dict:
    """master.run(ssp, algorithm="jacobi", output=None, record=[last.y]). The stepping phase is timed by
    wrapping the step loop (master.execution.Execution._steps; master.runner._loop in versions before the
    Execution API): algorithm step + observers (recording) per step. Cross-check by
    the difference method: wall_time_s of an N-step run minus that of a 1-step run, over N-1 steps.

    ``supervised``: as ``cosim-master run`` does by default (master.supervise.run_supervised: the simulation in
    a forked child, its rows in shared memory and through a pipe, Parquet and CSV written by this process into
    a temporary folder); the child's step loop reports its wall time through a file. ``files``: unsupervised,
    but Parquet and CSV written to a temporary folder as a supervised run writes them."""
    import inspect

    sys.path.insert(0, str(ROOT))
    import master
    import master.runner as runner

    n, steps, h, every, last = a["n"], a["steps"], a["step"], a["every"], a["last"]
    kw = dict(algorithm=a.get("algorithm", "jacobi"), step=h, output=None, record=[f"{last}.y"])
    supervised, files = a.get("supervised", False), a.get("files", False)
    folder = Path(tempfile.mkdtemp(prefix="chain_cosim_master_"))
    marks_file = folder / "step_loop_s"
    runs = iter(range(1000))
    if supervised or files:
        kw.pop("output")
        if supervised:
            from master.supervise import run_supervised as run_to_folder
        else:
            run_to_folder = master.run

        def simulate(ssp, **opts):
            return run_to_folder(ssp, output=folder / f"run{next(runs)}", **opts)
    else:
        simulate = master.run
    extra = {"cosim_master_version": getattr(master, "__version__", "?")}
    for opt in ("inprocess", "native_loop"):
        if opt in a:
            params = inspect.signature(runner.run).parameters
            if opt in params or any(p.kind == p.VAR_KEYWORD for p in params.values()):
                kw[opt] = a[opt]
            else:
                raise RuntimeError(f"this cosim-master has no '{opt}' option")
    marks = []
    try:
        from master.execution import Execution
        owner, attr = Execution, "_steps"
    except ImportError:
        owner, attr = runner, "_loop"
    orig_loop = getattr(owner, attr, None)
    if orig_loop is not None:
        def timed_loop(*args, **kwargs):
            t0 = perf()
            try:
                return orig_loop(*args, **kwargs)
            finally:
                marks.append(perf() - t0)
                with open(marks_file, "a") as f:        # a supervised run's loop is in its child
                    f.write(f"{marks[-1]!r}\n")
        setattr(owner, attr, timed_loop)

    simulate(a["ssp"], stop_time=h, **kw)          # warm-up: lazy imports, page cache
    try:        # a one-step run does not reach the native loop; a supervised child would import it each time
        from master.drivers.native import library
        library()
    except ImportError:       # versions before the native loop
        pass
    t_all = perf()
    res = simulate(a["ssp"], stop_time=steps * h, **kw)
    total = perf() - t_all
    one = simulate(a["ssp"], stop_time=h, **kw)
    if marks_file.is_file():
        marks = [float(x) for x in marks_file.read_text().split()]
    meta = res.metadata
    diff = (meta["wall_time_s"] - one.metadata["wall_time_s"]) / (steps - 1)
    extra["difference_method_us_per_fmu_step"] = diff / n * 1e6
    extra["metadata"] = {k: meta.get(k) for k in ("wall_time_s", "outcome", "algorithm", "steps", "step_size",
                                                  "algorithm_info", "rows_recorded", "package_version",
                                                  "native_loop")}
    modes = {k: True for k, on in (("supervised", supervised), ("files", files)) if on}
    extra["kwargs"] = {k: v for k, v in kw.items() if k != "record"} | modes
    frame = res.frame
    col = f"{last}.y"
    ys = frame[col].to_numpy()
    ts = frame["time"].to_numpy()
    if len(ys) != steps + 1:
        raise RuntimeError(f"expected {steps + 1} recorded rows, got {len(ys)}")
    samples = {k: float(ys[k]) for k in range(0, steps + 1, every)}
    samples[steps] = float(ys[steps])
    extra["last_time"] = float(ts[-1])
    import shutil
    shutil.rmtree(folder, ignore_errors=True)
    if marks:
        stepping, how = marks[1], f"wrapped {owner.__name__}.{attr} (step loop incl. recording), warm process"
    else:
        stepping, how = diff * steps, "difference method: (wall_time_s(N steps) - wall_time_s(1 step)) / (N-1)"
    return {"stepping_s": stepping, "steps_timed": steps, "timing": how, "total_s": total, "samples": samples,
            "extra": extra}


# ---------------------------------------------------------------------------------------------------
# (c) Ecos through ecospy


def _preload_tbb():
    """ecospy's wheel links libtbb.so.12 without shipping it; the 'tbb' wheel has it under <prefix>/lib."""
    import glob
    import site
    roots = [sys.prefix, sys.base_prefix, *site.getsitepackages()]
    for r in roots:
        for cand in glob.glob(os.path.join(r, "**", "libtbb.so.12*"), recursive=True):
            ctypes.CDLL(cand, mode=ctypes.RTLD_GLOBAL)
            return cand
    return None


def peer_ecospy(a: dict) -> dict:
    """EcosSimulation(ssp_path, step_size); init(); timed: step(every) repeated, get_real after each
    chunk. Ecos's fixed-step algorithm steps the instances with std::execution::par (TBB), i.e. in parallel
    on all cores of the process's affinity mask; pinned with taskset it runs on one."""
    tbb = _preload_tbb()
    import ecospy
    from ecospy import EcosLib, EcosSimulation

    n, steps, h, every, last = a["n"], a["steps"], a["step"], a["every"], a["last"]
    EcosLib.set_log_level("warn")
    t_all = perf()
    sim = EcosSimulation(ssp_path=str(a["ssp"]), step_size=h)
    if sim.init() is False:
        raise RuntimeError("ecos init failed: " + EcosLib.get_last_error())
    ident = f"{last}::y"
    samples = {0: sim.get_real(ident)}
    get, step = sim.get_real, sim.step
    t0 = perf()
    k = 0
    while k < steps:
        chunk = min(every, steps - k)
        step(chunk)
        k += chunk
        samples[k] = get(ident)
    t1 = perf()
    end_time = sim.get_time()
    sim.terminate()
    sim.free()
    v = EcosLib.version()
    return {"stepping_s": t1 - t0, "steps_timed": steps, "timing": "perf_counter around step() calls after init()",
            "total_s": perf() - t_all, "samples": samples,
            "extra": {"ecos_version": f"{v.major}.{v.minor}.{v.patch}", "tbb": tbb, "end_time": end_time,
                      "ecospy_file": ecospy.__file__}}


# ---------------------------------------------------------------------------------------------------
# (d) libcosim through libcosimpy


def peer_libcosimpy(a: dict) -> dict:
    """CosimExecution.from_ssp_file(ssp, step_size in ns) with a last-value observer. libcosim initializes
    lazily in the first step, so step 1 is untimed; timed: steps 2..N in chunks, reading the observer after
    each chunk. libcosim's fixed-step algorithm runs the slaves on a worker-thread pool."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    n, steps, h, every, last = a["n"], a["steps"], a["step"], a["every"], a["last"]
    log_output_level(CosimLogLevel.WARNING)
    t_all = perf()
    ex = CosimExecution.from_ssp_file(str(a["ssp"]), step_size=int(round(h * 1e9)))
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    idx = ex.slave_index_from_instance_name(last)
    vrs = {v.name.decode(): v.reference for v in ex.slave_variables(idx)}
    vr_y = vrs["y"]
    if not ex.step(1):
        raise RuntimeError("libcosim: first step (initialization) failed")
    samples = {}
    t0 = perf()
    k = 1
    while k < steps:
        chunk = min(every - k % every, steps - k)
        if not ex.step(chunk):
            raise RuntimeError(f"libcosim: step failed after step {k}")
        k += chunk
        if k % every == 0 or k == steps:
            samples[k] = obs.last_real_values(idx, [vr_y])[0]
    t1 = perf()
    status = ex.status()
    end_ns = getattr(status, "current_time", None)
    del obs, ex
    try:
        from libcosimpy.__about__ import __version__ as ver
    except Exception:
        ver = "?"
    return {"stepping_s": t1 - t0, "steps_timed": steps - 1,
            "timing": "perf_counter around steps 2..N (step 1 initializes lazily)",
            "total_s": perf() - t_all, "samples": samples,
            "extra": {"libcosimpy_version": ver, "end_time_ns": end_ns}}


# ---------------------------------------------------------------------------------------------------
# (e) fmpy's SSP runner


def peer_fmpy_ssp(a: dict) -> dict:
    """fmpy.ssp.simulation.simulate_ssp(ssp, stop_time=(N-0.5) h, step_size=h): its loop runs
    'while time < stop_time: time += h', so (N-0.5) h gives exactly N steps despite the accumulated time.
    The stepping phase is timed by wrapping the module's instantiate_fmu (end of the last one) and free_fmu
    (start of the first one), looked up by simulate_ssp at call time. Row j of its result holds the values
    after step j+1 (it records after stepping, at the time the step started)."""
    import fmpy
    import fmpy.ssp.simulation as S

    n, steps, h, every, last = a["n"], a["steps"], a["step"], a["every"], a["last"]
    marks = {}
    orig_inst, orig_free = S.instantiate_fmu, S.free_fmu

    def inst(*args, **kw):
        r = orig_inst(*args, **kw)
        marks["inst_end"] = perf()
        return r

    def free(*args, **kw):
        marks.setdefault("free_start", perf())
        return orig_free(*args, **kw)

    S.instantiate_fmu, S.free_fmu = inst, free
    t_all = perf()
    res = S.simulate_ssp(str(a["ssp"]), start_time=0.0, stop_time=(steps - 0.5) * h, step_size=h)
    total = perf() - t_all
    col = f"{last}.y"
    ys = res[col]
    if len(ys) != steps:
        raise RuntimeError(f"expected {steps} result rows, got {len(ys)}")
    samples = {k: float(ys[k - 1]) for k in range(every, steps + 1, every)}
    samples[steps] = float(ys[steps - 1])
    return {"stepping_s": marks["free_start"] - marks["inst_end"], "steps_timed": steps,
            "timing": "from the end of the last instantiate_fmu to the first free_fmu (wrapped)",
            "total_s": total, "samples": samples,
            "extra": {"fmpy_version": fmpy.__version__, "first_row_time": float(res["time"][0])}}


PEERS = {
    "bare_ctypes": peer_bare_ctypes,
    "cosim_master": peer_cosim_master,
    "ecospy": peer_ecospy,
    "libcosimpy": peer_libcosimpy,
    "fmpy_ssp": peer_fmpy_ssp,
}


def main(argv):
    name, args = argv[1], json.loads(argv[2])
    try:
        out = PEERS[name](args)
        out["ok"] = True
        out["samples"] = {str(k): float(v) for k, v in out["samples"].items()}
    except BaseException as exc:  # reported as a row with the reason, never a crash of the harness
        tb = traceback.format_exc()
        sys.stderr.write(tb)
        out = {"ok": False, "error": f"{type(exc).__name__}: {' '.join(str(exc).split())[:400]}"}
    out["pid"] = os.getpid()
    try:
        out["affinity"] = sorted(os.sched_getaffinity(0))
    except AttributeError:
        pass
    sys.stdout.write("\nCHAIN-RESULT " + json.dumps(out, default=str) + "\n")
    sys.stdout.flush()
    # some peers' native thread pools or embedded interpreters misbehave at exit: leave at once
    os._exit(0)


if __name__ == "__main__":
    main(sys.argv)
