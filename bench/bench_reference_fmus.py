"""The Modelica Reference FMUs in cosim-master and in fmpy, side by side: does each run, as co-simulation and as
model exchange, and does it match the reference results by the FMI cross-check rule?

    python bench/bench_reference_fmus.py [--shared ../shared] [--until-fraction 1.0]

For every FMU in shared/reference-fmus/fmi2 and fmi3 and every kind it offers, both tools run it from its
default experiment (cosim-master as a one-component SSP; fmpy with ``simulate_fmu``) and each signal of
ref/<Model>_out.csv is compared at the reference's time points: "ok" when every sample is within 10 % of the
signal's range (the cross-check band), "off" with the worst excess otherwise, or the one-line error. Prints a
table (and the wall time of each run).

Feedthrough runs without its input file, as its reference results were made (every output stays at its start
value); driven by ref/Feedthrough_in.csv it is checked by the hold rule in tests/master/fmi/test_input_files.py.
BouncingBall and VanDerPol as model exchange are "off" for both tools for a reason no importer can change:
their references are forward Euler at the FMU's fixed step, and the exact solutions are themselves outside
the band (tests/master/fmi/test_reference_fmus.py shows it, and that ``--solver euler`` reproduces them).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _kinds(fmu: Path) -> list[str]:
    from fmpy import read_model_description
    md = read_model_description(str(fmu))
    return [k for k, present in (("CoSimulation", md.coSimulation), ("ModelExchange", md.modelExchange)) if present]


def _verdict(times, columns: dict, ref: pd.DataFrame) -> str:
    worst = 0.0
    for col in ref.columns[1:]:
        if col not in columns:
            continue
        try:
            want = ref[col].to_numpy(dtype=float)
            got = np.interp(ref["time"].to_numpy(dtype=float), times, np.asarray(columns[col], dtype=float))
        except (TypeError, ValueError):
            continue          # strings, binaries: not a numeric signal
        band = 0.1 * max(np.ptp(want), 1e-12) + 1e-9 * np.max(np.abs(want))
        worst = max(worst, float(np.max(np.abs(got - want)) / band))
    return "ok" if worst <= 1.0 else f"off ({worst:.1f}x band)"


def run_cosim(fmu: Path, model: str, kind: str, tmp: Path) -> tuple[str, float]:
    import master
    from master.ssp.writer import SspBuilder
    b = SspBuilder(model.lower())
    b.add_component("m", fmu)
    ssp = b.write(tmp / f"{model}_{kind}.ssp")
    t0 = time.perf_counter()
    try:
        r = master.run(ssp, output=None, record=["m.*"], implementation={"m": kind})
    except master.CosimError as exc:
        return f"error: {str(exc)[-90:]}", time.perf_counter() - t0
    wall = time.perf_counter() - t0
    df = r.frame
    ref = pd.read_csv(ROOT.parent / "shared" / "reference-fmus" / "ref" / f"{model}_out.csv")
    cols = {c[2:]: df[c].to_numpy() for c in df.columns if c.startswith("m.")}
    return _verdict(df["time"].to_numpy(), cols, ref), wall


def run_fmpy(fmu: Path, model: str, kind: str) -> tuple[str, float]:
    from fmpy import simulate_fmu
    t0 = time.perf_counter()
    try:
        res = simulate_fmu(str(fmu), fmi_type=kind)
    except Exception as exc:   # noqa: BLE001 - a peer's failure is a row, not a crash of the harness
        return f"error: {' '.join(str(exc).split())[-90:]}", time.perf_counter() - t0
    wall = time.perf_counter() - t0
    ref = pd.read_csv(ROOT.parent / "shared" / "reference-fmus" / "ref" / f"{model}_out.csv")
    cols = {name: res[name] for name in res.dtype.names if name != "time"}
    return _verdict(res["time"], cols, ref), wall


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", default=str(ROOT.parent / "shared"))
    args = ap.parse_args(argv)
    ref_root = Path(args.shared) / "reference-fmus"
    if not ref_root.is_dir():
        print(f"no reference FMUs in {ref_root}")
        return 1
    import fmpy.fmi1
    fmpy.fmi1._FMU.freeLibrary = lambda self: None     # see tests/conftest.py: keep libraries loaded
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for version in ("fmi2", "fmi3"):
            for fmu in sorted((ref_root / version).glob("*.fmu")):
                model = fmu.stem
                if not (ref_root / "ref" / f"{model}_out.csv").is_file():
                    rows.append((version, model, "-", "no reference results", "", "", ""))
                    continue
                for kind in _kinds(fmu):
                    ours, t_ours = run_cosim(fmu, model, kind, Path(tmp))
                    theirs, t_theirs = run_fmpy(fmu, model, kind)
                    rows.append((version, model, kind, ours, f"{t_ours:.2f}", theirs, f"{t_theirs:.2f}"))
    print("| FMI | model | kind | cosim-master | s | fmpy | s |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(r) + " |")
    ok = [sum(1 for r in rows if r[i] == "ok") for i in (3, 5)]
    print(f"\nwithin the cross-check band over the whole default experiment: cosim-master {ok[0]}, fmpy {ok[1]} "
          f"of {sum(1 for r in rows if r[2] != '-')} runs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
