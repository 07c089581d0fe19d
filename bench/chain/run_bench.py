"""Chain benchmark: master overhead per FMU step, cosim-master side by side with its peers.

    python bench/chain/run_bench.py [--fmus 10] [--steps 10000] [--step 0.001] [--repeats 3] [--supervised]

A chain of --fmus first-order lags (lag{i-1}.y -> lag{i}.u; lag0.u unconnected), --steps fixed steps of
--step seconds, in two flavours of the same model: a native C FMI 2.0 co-simulation FMU (bench/chain/lag.c,
gcc against fmpy's FMI headers) and a pythonfmu FMU (bench/chain/Lag.py). Every master runs the same SSP
in its own subprocess (peers.py), pinned to core 0 with taskset unless the row says otherwise, --repeats
times, interleaved; the table shows the median of the timed stepping phase per FMU step:
wall / (n_fmus * n_steps_timed). Start-up (loading, instantiation, initialization) is excluded as each
peer's API allows: see the "timing" column of the details and bench/README.md.

Every master's trajectory of the last FMU (every --every steps and the final value) is checked against the
closed-form recurrence recomputed here (Jacobi: all inputs from the outputs at the start of the step,
initial outputs after initialization) to 1e-9 relative; a peer that matches another semantics instead
(first-step inputs 0, Gauss-Seidel, a one-step shift) is named as such.

--supervised measures cosim-master as ``cosim-master run`` runs by default (the simulation in a supervised
child process), native loop on and off, beside its unsupervised default, Ecos pinned and the bare loop.

Results: printed, and written to bench/results/chain_<date>.md and .json, or chain_<date>_supervised.* with
--supervised (unless --no-write).
A peer that cannot be installed, loaded or run gets a row with the reason; the harness does not fail.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import importlib.metadata as md
import importlib.util
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))

import build  # noqa: E402  (bench/chain/build.py)

MARK = "CHAIN-RESULT "
TOL = 1e-9

# label, peer, options, pinned, note
ROWS = [
    ("bare ctypes loop (CDLL)", "bare_ctypes", {}, True,
     "floor: per step and FMU fmi2SetReal(1) + fmi2DoStep + fmi2GetReal(1) through ctypes.CDLL"),
    ("bare ctypes loop (PyDLL, GIL kept)", "bare_ctypes", {"dll": "PyDLL"}, True,
     "same loop through ctypes.PyDLL, which does not release the GIL around each call"),
    ("cosim-master (defaults)", "cosim_master", {}, True,
     "master.run(..., algorithm='jacobi', output=None, record=[last.y]) with its default options"),
    ("cosim-master (native_loop=False)", "cosim_master", {"native_loop": False}, True,
     "the step loop in Python (the path before the native loop, and still the path of every system the "
     "native loop does not apply to), as --no-native-loop"),
    ("cosim-master (inprocess=False)", "cosim_master", {"inprocess": False}, True,
     "pythonfmu FMUs through their binary (FMI C API) instead of in-process; no effect on C FMUs"),
    ("ecospy pinned (taskset -c 0)", "ecospy", {}, True,
     "Ecos fixed-step algorithm (std::execution::par over TBB) on one core"),
    ("ecospy unpinned (TBB parallel)", "ecospy", {}, False,
     "same, all cores: Ecos steps the instances in parallel (its default; no switch in its C API)"),
    ("libcosimpy pinned (taskset -c 0)", "libcosimpy", {}, True,
     "libcosim fixed_step_algorithm (worker-thread pool) on one core"),
    ("libcosimpy unpinned (worker threads)", "libcosimpy", {}, False,
     "same, all cores"),
    ("fmpy simulate_ssp", "fmpy_ssp", {}, True,
     "fmpy.ssp.simulation.simulate_ssp, a pure-Python loop over fmpy's FMU2Slave"),
]

# --supervised: the chain as `cosim-master run` runs it by default (the simulation in a supervised child)
SUPERVISED_ROWS = [ROWS[0],
                   ("cosim-master supervised (defaults)", "cosim_master", {"supervised": True}, True,
                    "master.supervise.run_supervised(..., algorithm='jacobi', record=[last.y]) as `cosim-master "
                    "run` does: the simulation in a forked child, rows through shared memory and a pipe, Parquet "
                    "and CSV written by the parent; the child's step loop is timed"),
                   ("cosim-master supervised (native_loop=False)", "cosim_master",
                    {"supervised": True, "native_loop": False}, True,
                    "the same with the step loop in Python, as `cosim-master run --no-native-loop`"),
                   ("cosim-master (files)", "cosim_master", {"files": True}, True,
                    "unsupervised (master.run), but writing Parquet and CSV to a folder as the supervised rows do "
                    "(the other rows record to memory): what supervision itself costs is the difference"),
                   ("cosim-master (files, native_loop=False)", "cosim_master", {"files": True, "native_loop": False},
                    True, "the same with the step loop in Python"),
                   ROWS[2],
                   ROWS[5]]

# packages each peer needs, and what 'pip install' gives them (ecospy's wheel needs libtbb.so.12 from tbb)
REQUIRES = {"ecospy": ["ecospy", "tbb"], "libcosimpy": ["libcosimpy"], "fmpy_ssp": ["fmpy"],
            "cosim_master": [], "bare_ctypes": []}
# flavour -> name in the tables; the mixed chain (C and pythonfmu instances alternating) only for cosim-master
FLAVOURS = {"c": "native C", "py": "pythonfmu", "mix": "mixed C + pythonfmu"}
MIX_PEERS = {"cosim_master"}
IMPORT_NAME = {"ecospy": "ecospy", "tbb": None, "libcosimpy": "libcosimpy", "fmpy": "fmpy"}


# ---------------------------------------------------------------------------------------------------
# environment


def _version(dist: str) -> str | None:
    try:
        return md.version(dist)
    except md.PackageNotFoundError:
        return None


def _tbb_present() -> bool:
    import glob
    import site
    for r in {sys.prefix, sys.base_prefix, *site.getsitepackages()}:
        if glob.glob(os.path.join(r, "**", "libtbb.so.12*"), recursive=True):
            return True
    return False


def _missing(pkg: str) -> bool:
    if pkg == "tbb":
        return not _tbb_present()
    name = IMPORT_NAME.get(pkg, pkg)
    return importlib.util.find_spec(name) is None


def ensure_packages(install: bool) -> dict[str, str]:
    """{peer: reason} for peers whose packages are missing (after trying pip install, if allowed)."""
    problems = {}
    for peer, pkgs in REQUIRES.items():
        missing = [p for p in pkgs if _missing(p)]
        if missing and install:
            print(f"installing {' '.join(missing)} for {peer} ...", flush=True)
            proc = subprocess.run([sys.executable, "-m", "pip", "install", "-q", *missing], capture_output=True,
                                  text=True, timeout=600)
            if proc.returncode != 0:
                last = (proc.stderr.strip().splitlines() or ["?"])[-1]
                problems[peer] = f"pip install {' '.join(missing)} failed: {last[:200]}"
                continue
            importlib.invalidate_caches()
            missing = [p for p in pkgs if _missing(p)]
        if missing:
            problems[peer] = f"not installed: {', '.join(missing)}" + ("" if install else " (--no-install)")
    return problems


def machine_description() -> dict:
    def sh(cmd):
        try:
            return subprocess.run(cmd, shell=True, capture_output=True, text=True, timeout=30).stdout.strip()
        except Exception as exc:  # pragma: no cover
            return f"({exc})"
    versions = {d: _version(d) for d in ("cosim-master", "fmpy", "ecospy", "tbb", "libcosimpy", "pythonfmu", "numpy",
                                        "pandas")}
    return {
        "date": _dt.datetime.now().isoformat(timespec="seconds"),
        "lscpu": sh("lscpu | grep -v '^Flags' | head -n 20"),
        "nproc": os.cpu_count(),
        "python": sys.version.split()[0],
        "python_executable": sys.executable,
        "platform": platform.platform(),
        "gcc": sh("gcc --version | head -n 1"),
        "versions": versions,
        "git_head": sh(f"git -C {ROOT} rev-parse --short HEAD 2>/dev/null"),
        "git_dirty_master": bool(sh(f"git -C {ROOT} status --porcelain -- master 2>/dev/null")),
    }


# ---------------------------------------------------------------------------------------------------
# reference trajectories (same floating-point operations as lag.c / Lag.py)


def reference(n, steps, h, mode, T=1.0, k=1.0, x0=1.0) -> dict[int, float]:
    """y of the last FMU after k steps, for every k in 0..steps. Modes:
    jacobi          inputs of step s are the outputs after step s-1 (after initialization for s = 0)
    jacobi_zero0    the same, but every connected input is 0 in the first step (no initial transfer)
    gauss_seidel    lag i reads lag i-1's output of the same step"""
    import numpy as np

    y = np.full(n, x0)
    out = {0: float(y[-1])}
    u = np.zeros(n)
    for s in range(steps):
        if mode == "gauss_seidel":
            prev = 0.0
            for i in range(n):
                ui = prev if i else 0.0
                y[i] = y[i] + h * (k * ui - y[i]) / T
                prev = y[i]
        else:
            u[0] = 0.0
            u[1:] = 0.0 if (mode == "jacobi_zero0" and s == 0) else y[:-1]
            y = y + h * (k * u - y) / T
        out[s + 1] = float(y[-1])
    return out


def compare(samples: dict[int, float], ref: dict[int, float], shift: int = 0) -> float | None:
    """Largest relative difference over the common sample points (peer's k vs the reference's k+shift)."""
    errs = []
    for k, v in samples.items():
        r = ref.get(k + shift)
        if r is None:
            continue
        errs.append(abs(v - r) / max(abs(r), 1e-300))
    return max(errs) if errs else None


WHY = {
    ("jacobi_zero0", 0): "its first step sees the connected inputs as 0 instead of the outputs after "
                         "initialization (no transfer before the first step)",
    ("gauss_seidel", 0): "Gauss-Seidel semantics (each FMU sees its predecessor's output of the same step)",
    ("jacobi", 1): "one step ahead of the Jacobi reference (sample k holds the value after k+1 steps)",
    ("jacobi", -1): "one step behind the Jacobi reference (sample k holds the value after k-1 steps)",
}


def classify(samples: dict[int, float], refs: dict[str, dict[int, float]]) -> tuple[str, dict]:
    """A short verdict, and the largest relative difference against each candidate semantics."""
    errs = {}
    for name, ref in refs.items():
        for shift in (0, -1, 1):
            e = compare(samples, ref, shift)
            if e is not None:
                errs[f"{name}{'' if shift == 0 else f'{shift:+d}'}"] = (e, name, shift)
    j = errs.get("jacobi", (None,))[0]
    table = {k: v[0] for k, v in errs.items()}
    if j is not None and j <= TOL:
        return f"ok: = Jacobi reference (max rel diff {j:.1e})", table
    best = min(errs.values(), default=None)
    if best is not None and best[0] <= TOL:
        why = WHY.get((best[1], best[2]), f"{best[1]} shifted by {best[2]}")
        return f"DIFFERS from Jacobi (max rel {j:.1e}): {why}", table
    return f"DIFFERS from every reference (max rel vs Jacobi {j if j is not None else float('nan'):.1e})", table


# ---------------------------------------------------------------------------------------------------
# running peers


def run_peer(peer: str, args: dict, pinned: bool, timeout: float) -> dict:
    cmd = [sys.executable, str(HERE / "peers.py"), peer, json.dumps(args)]
    preexec = None
    if pinned:
        if shutil.which("taskset"):
            cmd = ["taskset", "-c", "0", *cmd]
        elif hasattr(os, "sched_setaffinity"):
            def preexec():
                os.sched_setaffinity(0, {0})
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, preexec_fn=preexec,
                              cwd=str(ROOT))
    except subprocess.TimeoutExpired:
        return {"ok": False, "error": f"timed out after {timeout:g} s"}
    wall = time.perf_counter() - t0
    for line in reversed(proc.stdout.splitlines()):
        if line.startswith(MARK):
            res = json.loads(line[len(MARK):])
            res["process_s"] = wall
            if not res.get("ok"):
                res["stderr_tail"] = proc.stderr.strip().splitlines()[-5:]
            return res
    tail = " | ".join((proc.stderr.strip().splitlines() or ["no output"])[-3:])
    return {"ok": False, "error": f"exit code {proc.returncode} without a result: {tail[:300]}",
            "process_s": wall}


def fmt(x, spec=".2f", none="—"):
    return none if x is None else format(x, spec)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fmus", type=int, default=10, help="FMUs in the chain (default 10)")
    ap.add_argument("--steps", type=int, default=10000, help="master steps (default 10000)")
    ap.add_argument("--step", type=float, default=0.001, help="step size in s (default 0.001)")
    ap.add_argument("--repeats", type=int, default=5, help="runs per master and flavour; the best is shown")
    ap.add_argument("--every", type=int, default=100, help="trajectory sample interval in steps (default 100)")
    ap.add_argument("--timeout", type=float, default=600, help="seconds per peer subprocess (default 600)")
    ap.add_argument("--only", default="", help="comma-separated peer names to run (default: all)")
    ap.add_argument("--supervised", action="store_true",
                    help="cosim-master supervised (as the CLI runs) with the native loop on and off, against Ecos "
                         "pinned; written to chain_<date>_supervised.md")
    ap.add_argument("--no-install", action="store_true", help="do not pip install missing peers")
    ap.add_argument("--no-write", action="store_true", help="print only; write nothing to bench/results")
    ap.add_argument("--results-dir", default=str(ROOT / "bench" / "results"))
    a = ap.parse_args(argv)
    if a.fmus < 2 or a.steps < 2 or a.every < 1 or a.step <= 0:
        ap.error("need --fmus >= 2, --steps >= 2, --every >= 1, --step > 0")
    t_start = time.perf_counter()

    only = {s.strip() for s in a.only.split(",") if s.strip()}
    rows = [r for r in (SUPERVISED_ROWS if a.supervised else ROWS) if not only or r[1] in only]
    problems = ensure_packages(not a.no_install)
    machine = machine_description()
    load_before = os.getloadavg() if hasattr(os, "getloadavg") else None

    print(f"building the chain: {a.fmus} FMUs, {a.steps} steps of {a.step:g} s ...", flush=True)
    built = build.build_all(HERE / "build", a.fmus, a.steps, a.step)
    flavours = tuple(FLAVOURS)
    last = f"lag{a.fmus - 1}"
    common = {"n": a.fmus, "steps": a.steps, "step": a.step, "every": a.every, "last": last}

    refs = {m: reference(a.fmus, a.steps, a.step, m) for m in ("jacobi", "jacobi_zero0", "gauss_seidel")}

    runs: dict[tuple[int, str], list[dict]] = {}
    for rep in range(a.repeats):
        for ri, (label, peer, opts, pinned, _note) in enumerate(rows):
            for fl in flavours:
                key = (ri, fl)
                if peer in problems:
                    runs.setdefault(key, []).append({"ok": False, "error": problems[peer]})
                    continue
                if fl == "mix" and peer not in MIX_PEERS:
                    runs.setdefault(key, []).append({"ok": False, "error": "not measured"})
                    continue
                if "error" in built[fl]:
                    runs.setdefault(key, []).append({"ok": False, "error": "build failed: " + built[fl]["error"]})
                    continue
                args = {**common, **opts, "ssp": str(built[fl]["ssp"]), "fmu": str(built[fl]["fmu"])}
                res = run_peer(peer, args, pinned, a.timeout)
                runs.setdefault(key, []).append(res)
                us = (res["stepping_s"] / (a.fmus * res["steps_timed"]) * 1e6) if res.get("ok") else None
                print(f"  [{rep + 1}/{a.repeats}] {label:40s} {fl:2s} "
                      + (f"{us:8.3f} us/FMU-step" if us is not None else "FAILED: " + res.get("error", "?")),
                      flush=True)

    # aggregate
    table = []
    for ri, (label, peer, opts, pinned, note) in enumerate(rows):
        entry = {"label": label, "peer": peer, "options": opts, "pinned": pinned, "note": note}
        for fl in flavours:
            rs = runs.get((ri, fl), [])
            good = [r for r in rs if r.get("ok")]
            cell = {"runs": len(rs), "ok_runs": len(good)}
            if good:
                per = [r["stepping_s"] / (a.fmus * r["steps_timed"]) * 1e6 for r in good]
                cell["us_per_fmu_step"] = min(per)         # best of the repeats, as timeit does
                cell["median_us"] = statistics.median(per)
                cell["all_us"] = per
                cell["timing"] = good[0]["timing"]
                cell["total_s"] = statistics.median(r["total_s"] for r in good)
                cell["extra"] = good[0].get("extra", {})
                samples = {int(k): v for k, v in good[0]["samples"].items()}
                verdict, errs = classify(samples, refs)
                # all repeats must give the same trajectory
                spread = max((compare({int(k): v for k, v in r["samples"].items()}, samples) or 0.0)
                             for r in good)
                cell["trajectory"] = verdict + ("" if spread <= TOL else f"; repeats differ by {spread:.1e}")
                cell["errors"] = errs
                cell["final"] = samples.get(a.steps)
                if len(good) < len(rs):
                    cell["note"] = f"{len(rs) - len(good)} of {len(rs)} runs failed: " + \
                        next(r.get("error", "?") for r in rs if not r.get("ok"))
            else:
                cell["error"] = rs[0].get("error", "?") if rs else "not run"
            entry[fl] = cell
        table.append(entry)

    def base_of(peer_label_prefix):
        for e in table:
            if e["label"].startswith(peer_label_prefix):
                return e
        return None

    bare, ecos = base_of("bare ctypes loop (CDLL)"), base_of("ecospy pinned")
    for e in table:
        for fl in flavours:
            c = e[fl]
            for name, b in (("ratio_bare", bare), ("ratio_ecos", ecos)):
                bv = b[fl].get("us_per_fmu_step") if b else None
                c[name] = c["us_per_fmu_step"] / bv if (bv and c.get("us_per_fmu_step") is not None) else None

    machine["loadavg_before"] = load_before
    machine["loadavg_after"] = os.getloadavg() if hasattr(os, "getloadavg") else None
    ref_final = refs["jacobi"][a.steps]
    grid = {k: v for k, v in refs["jacobi"].items() if k % a.every == 0 or k == a.steps}
    # how far apart the candidate semantics are on the sampled grid: what the 1e-9 check can tell apart
    sensitivity = {"one step shift": compare(grid, refs["jacobi"], 1),
                   "first-step inputs 0": compare(grid, refs["jacobi_zero0"]),
                   "Gauss-Seidel": compare(grid, refs["gauss_seidel"])}
    report = render(a, table, machine, ref_final, sensitivity, problems, time.perf_counter() - t_start)
    print()
    print(report["console"])
    if not a.no_write:
        out_dir = Path(a.results_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        stamp = _dt.date.today().isoformat()
        md_path = out_dir / f"chain_{stamp}{'_supervised' if a.supervised else ''}.md"
        md_path.write_text(report["markdown"], encoding="utf-8")
        md_path.with_suffix(".json").write_text(json.dumps(
            {"args": vars(a), "machine": machine, "reference_final": ref_final, "sensitivity": sensitivity,
             "table": table,
             "raw": {f"{rows[ri][0]} [{fl}]": [r if i == 0 else {k: v for k, v in r.items() if k != "samples"}
                                                 for i, r in enumerate(rs)]
                     for (ri, fl), rs in runs.items()}}, indent=1, default=str),
            encoding="utf-8")
        print(f"\nwritten: {md_path.relative_to(ROOT)} and {md_path.with_suffix('.json').relative_to(ROOT)}")
    return 0


def render(a, table, machine, ref_final, sensitivity, problems, elapsed) -> dict:
    fls = list(FLAVOURS)
    head = (["master"] + [f"{FLAVOURS[fl]} µs/FMU-step" for fl in fls]
            + [f"ratio to bare ctypes ({' / '.join(fls)})", f"ratio to ecospy pinned ({' / '.join(fls)})"])
    lines = []
    for e in table:
        def val(cell):
            if cell.get("us_per_fmu_step") is None:
                return "—" if cell.get("error") == "not measured" else "n/a: " + cell.get("error", "?")
            return fmt(cell["us_per_fmu_step"], ".3f")

        def ratio(key):
            rs = [e[fl].get(key) for fl in fls]
            if all(r is None for r in rs):
                return "—"
            return " / ".join(fmt(r) for r in rs)
        lines.append([e["label"], *(val(e[fl]) for fl in fls), ratio("ratio_bare"), ratio("ratio_ecos")])

    def md_table(hdr, rows):
        out = ["| " + " | ".join(hdr) + " |", "|" + "|".join("---" for _ in hdr) + "|"]
        out += ["| " + " | ".join(str(x).replace("|", "/") for x in r) + " |" for r in rows]
        return "\n".join(out)

    main_table = md_table(head, lines)
    traj = []
    for e in table:
        for fl, name in FLAVOURS.items():
            cell = e[fl]
            if cell.get("error") == "not measured":
                continue
            traj.append([e["label"], name, fmt(cell.get("final"), ".15g"),
                         cell.get("trajectory") or ("n/a: " + cell.get("error", "?"))])
    traj_table = md_table(["master", "flavour", f"final y of lag{a.fmus - 1}", "trajectory check"], traj)
    det = []
    for e in table:
        for fl, name in FLAVOURS.items():
            cell = e[fl]
            if cell.get("us_per_fmu_step") is None:
                continue
            runs = ", ".join(f"{x:.3f}" for x in cell["all_us"]) + f" (median {cell['median_us']:.3f})"
            x = cell.get("extra", {})
            more = ""
            if "difference_method_us_per_fmu_step" in x:
                more = f"difference method: {x['difference_method_us_per_fmu_step']:.3f} µs"
                info = (x.get("metadata") or {}).get("algorithm_info")
                if info:
                    more += f"; algorithm_info: {json.dumps(info, default=str)[:160]}"
                native = (x.get("metadata") or {}).get("native_loop")
                if native:
                    more += f"; native_loop: {json.dumps(native)}"
            if cell.get("note"):
                more = (more + "; " if more else "") + cell["note"]
            det.append([e["label"], name, runs, f"{cell['total_s']:.3f}", cell["timing"], more])
    det_table = md_table(["master", "flavour", "µs/FMU-step per run", "whole run in process (s, median)",
                          "how the stepping phase was timed", "notes"], det)
    sens = ", ".join(f"{k} {fmt(v, '.1e')}" for k, v in sensitivity.items())
    sens_verdict = ("; all above the tolerance, so the check tells them apart."
                    if all(v is not None and v > TOL for v in sensitivity.values()) else
                    "; NOT all above the tolerance: this horizon is too short for a discriminating check.")
    notes = "\n".join(f"- **{e['label']}**: {e['note']}" for e in table)
    ver = machine["versions"]
    setup = (f"{a.fmus} FMUs in a chain, {a.steps} steps of {a.step:g} s (= {a.fmus * a.steps} FMU steps per run), "
             f"{a.repeats} runs per cell, interleaved, best shown (medians in the details); each run in its own "
             f"subprocess; pinned rows run under `taskset -c 0`.")
    lb, la = machine.get("loadavg_before"), machine.get("loadavg_after")
    load = ""
    if lb and la:
        load = (f"Load average (1/5/15 min) before: {lb[0]:.2f} {lb[1]:.2f} {lb[2]:.2f}, after: "
                f"{la[0]:.2f} {la[1]:.2f} {la[2]:.2f} on {machine['nproc']} CPUs.")
        if max(lb[0], la[0]) > 0.5:
            load += (" **Other processes were running: absolute figures are inflated and noisy; the best-of "
                     "figures and the ratios within one run are the more reliable.**")
    flag = " --supervised" if a.supervised else ""
    md = f"""# Chain benchmark, {machine['date'][:10]}

Command: `python bench/chain/run_bench.py --fmus {a.fmus} --steps {a.steps} --step {a.step:g} --repeats {a.repeats}{flag}`
(total {elapsed:.0f} s). {setup} µs/FMU-step = wall time of the timed stepping phase / (FMUs × steps timed).
{load}

{main_table}

Reference final value (closed-form Jacobi recurrence, recomputed in the harness): {ref_final:.15g}.

## Trajectories

Every master's `lag{a.fmus - 1}.y` every {a.every} steps and at the end, against the reference to {TOL:g} relative.
On this grid the reference differs from the other candidate semantics by (max relative difference):
{sens}{sens_verdict}

{traj_table}

## Rows

{notes}

## Details

{det_table}

## Machine

```
{machine['lscpu']}
```

- python {machine['python']} ({machine['platform']}), {machine['gcc']}
- cosim-master {ver.get('cosim-master')} (git {machine['git_head']}{', master/ has uncommitted changes' if machine['git_dirty_master'] else ''}),
  fmpy {ver.get('fmpy')}, ecospy {ver.get('ecospy')} (+ tbb {ver.get('tbb')}), libcosimpy {ver.get('libcosimpy')},
  pythonfmu {ver.get('pythonfmu')}, numpy {ver.get('numpy')}, pandas {ver.get('pandas')}
""" + ("".join(f"- {peer}: {why}\n" for peer, why in problems.items()) if problems else "")
    console = main_table + "\n\n" + traj_table + ("\n\n" + load if load else "")
    return {"markdown": md, "console": console}


if __name__ == "__main__":
    sys.exit(main())
