"""A study's figures (PNG, matplotlib): error against step size with reference slopes, work against precision,
and the energy residual of runs that record one (a results column, or a column of the run's ``steps.csv`` as ECCO
writes it, whose name ends in ``energy_residual``, docs/coupling.md)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: the results column(s) the energy-residual figure plots (docs/coupling.md, "The study command")
ENERGY_RESIDUAL_SUFFIX = "energy_residual"


def _series(table):
    """(label, rows) per algorithm and extrapolation order, rows sorted by step."""
    out = {}
    for r in table:
        label = r["algorithm"] + (f", K={r['extrapolation']}" if r["extrapolation"] else "")
        out.setdefault(label, []).append(r)
    return {k: sorted(v, key=lambda r: r["step"]) for k, v in out.items()}


def _finite(rows, key):
    return [r for r in rows if isinstance(r[key], (int, float)) and math.isfinite(r[key]) and r[key] > 0]


def error_vs_step(table: list[dict], path: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    signals = list(dict.fromkeys(r["signal"] for r in table))
    cols = min(2, len(signals))
    rows_n = math.ceil(len(signals) / cols)
    fig, axes = plt.subplots(rows_n, cols, figsize=(5.5 * cols, 4.2 * rows_n), squeeze=False)
    for ax, signal in zip(axes.flat, signals):
        series = _series([r for r in table if r["signal"] == signal])
        anchors = []
        for label, rows in series.items():
            rows = _finite(rows, "error_max")
            if rows:
                ax.loglog([r["step"] for r in rows], [r["error_max"] for r in rows], "o-", label=label)
                anchors.append((rows[-1]["step"], rows[-1]["error_max"]))
        if anchors:
            # reference slopes through the geometric mean of the errors at the largest step
            h0 = max(h for h, _ in anchors)
            e0 = math.exp(np.mean([math.log(e) for h, e in anchors if h == h0]))
            steps = sorted({r["step"] for r in table})
            hs = np.array([steps[0], h0])
            for p, style in ((1, "k--"), (2, "k:")):
                ax.loglog(hs, e0 * (hs / h0) ** p, style, lw=1, label=f"order {p}")
        ax.set_xlabel("step h [s]")
        ax.set_ylabel(f"max |error| of {signal}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    for ax in list(axes.flat)[len(signals):]:
        ax.set_visible(False)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def work_precision(table: list[dict], path: Path) -> Path:
    """Error (the largest over the signals) against DoStep calls, one line per algorithm and order."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    per_run = {}
    for r in table:
        key = (r["algorithm"], r["extrapolation"], r["step"])
        e = r["error_max"]
        if isinstance(e, float) and math.isfinite(e):
            per_run[key] = {**r, "error_max": max(e, per_run.get(key, {}).get("error_max", 0.0))}
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for label, rows in _series(list(per_run.values())).items():
        rows = [r for r in _finite(rows, "error_max") if r["fmu_calls"]]
        if rows:
            rows.sort(key=lambda r: r["fmu_calls"])
            ax.loglog([r["fmu_calls"] for r in rows], [r["error_max"] for r in rows], "o-", label=label)
    ax.set_xlabel("FMU DoStep calls")
    ax.set_ylabel("max |error| (largest over the signals)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def energy_residual(frames: dict[str, object], path: Path) -> Path | None:
    """The energy residual over time of every run that records one; None when no run does."""
    curves = [(label, df["time"].to_numpy(), df[c].to_numpy(dtype=float), c)
              for label, df in frames.items() for c in df.columns if str(c).endswith(ENERGY_RESIDUAL_SUFFIX)]
    if not curves:
        return None
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for label, t, y, column in curves:
        ax.plot(t, y, label=f"{label}: {column}")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("energy residual")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
