"""A stability sweep (``cosim-master stability``): the spectral radius of the coupled step map (step_map.py) for
every scheme and step, optionally against one parameter's values, into stability.csv and stability.png
(Kuebler and Schiehlen 2000's comparison of coupling schemes by the spectral radius of their step map).

A scheme is an algorithm with its settings: Jacobi and Gauss-Seidel with each extrapolation order K, Gauss-Seidel
also with each interpolation order M, the iterative algorithm alone (its iteration settles the inputs, so K and M
do not apply to it). Where a point cannot be identified (a step map that overflows before enough steps are seen)
its row says why and the sweep goes on; bad input (an unknown parameter) stops it with one line. `fit_residual`
says how well a linear step map explains what was seen: round-off for a linear system, large where a nonlinear
one changes over the identification's steps.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import CosimError
from .step_map import FIXED_STEP, IdentificationError, identify

#: the iterative algorithm's settings for the analysis: its step map is that of the converged step, so the
#: iteration must converge far below the identification's own accuracy
ITERATIVE = {"coupling_tol": 1e-13, "coupling_max_iter": 200, "coupling_update": "aitken"}
STABLE_BELOW = 1.0 + 1e-9        # round-off above 1 is not an unstable scheme

COLUMNS = ["scenario", "scheme", "algorithm", "extrapolation", "gs_interpolation", "step", "parameter", "value",
           "spectral_radius", "growth_per_second", "stable", "dominant_eigenvalue_re", "dominant_eigenvalue_im",
           "order", "spacing", "fit_residual", "error"]


@dataclass(frozen=True)
class Scheme:
    algorithm: str
    extrapolation: int = 0
    gs_interpolation: int = 0

    @property
    def label(self) -> str:
        parts = [self.algorithm]
        if self.extrapolation:
            parts.append(f"K={self.extrapolation}")
        if self.gs_interpolation:
            parts.append(f"M={self.gs_interpolation}")
        return " ".join(parts)

    def options(self) -> dict:
        if self.algorithm == "iterative":
            return dict(ITERATIVE)
        return {"extrapolation": self.extrapolation, "gs_interpolation": self.gs_interpolation}


def schemes(algorithms, extrapolations=(0,), interpolations=(0,)) -> list[Scheme]:
    """The schemes of a grid, leaving out the combinations an algorithm does not take."""
    out = []
    for a in algorithms:
        if a not in FIXED_STEP:
            raise CosimError(f"the stability sweep takes the fixed-step algorithms ({', '.join(FIXED_STEP)}), "
                             f"not {a}", element="--algorithm")
        if a == "iterative":
            out.append(Scheme(a))
            continue
        for k in extrapolations:
            for m in (interpolations if a == "gauss-seidel" else (0,)):
                out.append(Scheme(a, int(k), int(m)))
    return list(dict.fromkeys(out))


def parse_vary(text: str | None) -> tuple[str, list[float]] | None:
    """``NAME=V1,V2,...`` (``--vary B.kc=1,10,100``) as (name, values)."""
    if not text:
        return None
    name, sep, values = text.partition("=")
    try:
        parsed = [float(v) for v in values.split(",") if v.strip()]
    except ValueError:
        parsed = []
    if not sep or not name.strip() or not parsed or not all(math.isfinite(v) for v in parsed):
        raise CosimError(f"expected NAME=V1,V2,... with numbers, got {text!r}", element="--vary")
    return name.strip(), parsed


def sweep(scenario, scheme_list: list[Scheme], steps, params: dict | None = None,
          vary: tuple[str, list[float]] | None = None, **identify_options) -> list[dict]:
    """One row per scheme, step and value of the varied parameter (COLUMNS)."""
    rows = []
    name, values = vary if vary else ("", [None])
    for value in values:
        run_params = dict(params or {})
        if value is not None:
            run_params[name] = value
        for scheme in scheme_list:
            for h in steps:
                row = {"scenario": Path(str(scenario)).name, "scheme": scheme.label, "algorithm": scheme.algorithm,
                       "extrapolation": scheme.extrapolation, "gs_interpolation": scheme.gs_interpolation,
                       "step": float(h), "parameter": name, "value": "" if value is None else value}
                try:
                    m = identify(scenario, algorithm=scheme.algorithm, step=float(h), params=run_params or None,
                                 **scheme.options(), **identify_options)
                except IdentificationError as exc:
                    rows.append({**row, **{k: "" for k in COLUMNS if k not in row}, "error": str(exc)})
                    continue
                rho = m.spectral_radius
                lead = m.eigenvalues[0] if m.order else 0j
                rows.append({**row, "spectral_radius": rho,
                             "growth_per_second": math.log(rho) / h if rho > 0 else -math.inf,
                             "stable": rho <= STABLE_BELOW, "dominant_eigenvalue_re": float(np.real(lead)),
                             "dominant_eigenvalue_im": float(np.imag(lead)), "order": m.order,
                             "spacing": m.settings["spacing"], "fit_residual": m.fit_residual, "error": ""})
    return rows


def write_csv(rows: list[dict], path: Path) -> Path:
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in r.items()})
    return path


def figure(rows: list[dict], path: Path, scenario: str) -> Path:
    """Spectral radius (left) and the growth it means per second, ln(radius) / h (right: comparable across
    steps, and what separates the schemes where every radius is within 1e-4 of 1), against the step, or against
    the varied parameter with one line per scheme and step; the title names the scenario, how the step map was
    found and the schemes."""
    import textwrap

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    ok = [r for r in rows if r["error"] == "" and r["spectral_radius"] > 0]
    varied = next((r["parameter"] for r in rows if r["parameter"]), "")
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.2))
    series: dict = {}
    for r in ok:
        key = r["scheme"] + (f", h={r['step']:g}" if varied else "")
        series.setdefault(key, []).append((r["value"] if varied else r["step"], r["spectral_radius"],
                                           r["growth_per_second"]))
    markers = "os^vD<>p*hx+"
    for i, (label, pts) in enumerate(series.items()):
        pts.sort()
        style = dict(marker=markers[i % len(markers)], mfc="none", ls="-" if i % 2 == 0 else "--", label=label)
        # hollow markers and alternating dashes keep coinciding schemes visible
        axes[0].plot([p[0] for p in pts], [p[1] for p in pts], **style)
        axes[1].plot([p[0] for p in pts], [p[2] for p in pts], **style)
    axes[0].axhline(1.0, color="k", lw=0.8)
    axes[1].axhline(0.0, color="k", lw=0.8)
    axes[0].set_yscale("log")
    axes[1].set_yscale("symlog", linthresh=1e-6)
    axes[0].set_ylabel("spectral radius of the coupled step map (stable <= 1)")
    axes[1].set_ylabel("growth per second ln(radius) / h [1/s]")
    for ax in axes:
        ax.set_xscale("log")
        ax.set_xlabel(f"{varied}" if varied else "step h [s]")
        ax.grid(True, which="both", alpha=0.3)
    if series:
        axes[0].legend(fontsize=7, ncol=2)
    schemes_shown = ", ".join(dict.fromkeys(r["scheme"] for r in rows))
    fig.suptitle(textwrap.fill(f"{scenario}: spectral radius of the coupled step map, identified from the FMUs "
                               f"(perturbed coupled values, ERA); schemes: {schemes_shown}", 140), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def run_stability(scenario, *, algorithms, extrapolations=(0,), interpolations=(0,), steps, output,
                  params: dict | None = None, vary: str | None = None) -> tuple[list[dict], list[Path]]:
    """The sweep written into ``output``: stability.csv and stability.png."""
    rows = sweep(scenario, schemes(algorithms, extrapolations, interpolations), steps, params, parse_vary(vary))
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    return rows, [write_csv(rows, out / "stability.csv"), figure(rows, out / "stability.png", Path(scenario).name)]
