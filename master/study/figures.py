"""A study's figures (PNG, matplotlib): error against step size with reference slopes, work against precision,
error against a swept tolerance, and the energy residual of runs that record one (a results column, or a column
of the run's ``steps.csv`` as ECCO writes it, whose name ends in ``energy_residual``, docs/coupling.md).

Every figure's title names the scenario, the reference and the schemes drawn; each series has its own marker
and line style (and hollow markers of decreasing size), so that series lying on top of each other (Gauss-Seidel
K = 1 and K = 2) both stay visible; log axes carry few, rotated tick labels so they do not run into each other."""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

#: the results column(s) the energy-residual figure plots (docs/coupling.md, "The study command")
ENERGY_RESIDUAL_SUFFIX = "energy_residual"
MARKERS = "osD^vP*Xph<>"
LINESTYLES = ["-", "--", "-.", ":", (0, (5, 1, 1, 1)), (0, (1, 1))]
#: the swept settings the tolerance figure plots errors against (the first one swept)
TOLERANCES = ("step_rtol", "step_atol", "coupling_tol")


def series_label(params: dict, axes: list[str]) -> str:
    """A run's algorithm and settings without its step."""
    label = params["algorithm"] + (f", K={params['extrapolation']}" if params.get("extrapolation") else "")
    return label + "".join(f", {a}={params[a]}" for a in axes if a in params)


def _series(table, axes, exclude=()):
    """(label, rows) per algorithm and settings, rows sorted by step."""
    out = {}
    for r in table:
        label = series_label({k: v for k, v in r.items() if k not in exclude}, [a for a in axes if a not in exclude])
        out.setdefault(label, []).append(r)
    return {k: sorted(v, key=lambda r: r["step"]) for k, v in out.items()}


def _style(j: int) -> dict:
    return {"marker": MARKERS[j % len(MARKERS)], "linestyle": LINESTYLES[j % len(LINESTYLES)],
            "markersize": max(4.0, 9.0 - 0.8 * j), "markerfacecolor": "none", "markeredgewidth": 1.3}


def _finite(rows, key):
    return [r for r in rows if r.get("outcome", "completed") == "completed"
            and isinstance(r[key], (int, float)) and math.isfinite(r[key]) and r[key] > 0]


def _title(fig, title: str, schemes) -> None:
    text = f"{title}\nschemes: {'; '.join(schemes)}"
    fig.suptitle("\n".join(textwrap.fill(line, 110) for line in text.split("\n")), fontsize=8)


def _log_ticks(ax) -> None:
    from matplotlib.ticker import LogLocator
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(LogLocator(base=10, numticks=6))
        axis.set_minor_locator(LogLocator(base=10, subs=np.arange(2, 10) * 0.1, numticks=12))
    ax.tick_params(axis="x", labelrotation=30, labelsize=8)
    ax.tick_params(axis="y", labelsize=8)


def _step_ticks(ax, steps) -> None:
    """The studied steps as the x tick labels (written as given: 0.005, not 5 x 10^-3), thinned to at most
    eight so they keep apart."""
    from matplotlib.ticker import FixedLocator, NullFormatter
    shown = steps[::max(1, math.ceil(len(steps) / 8))]
    ax.xaxis.set_major_locator(FixedLocator(shown))
    ax.xaxis.set_major_formatter(lambda x, _: f"{x:g}")
    ax.xaxis.set_minor_formatter(NullFormatter())


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: Path) -> Path:
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.5 / fig.get_figheight()))
    fig.savefig(path, dpi=120)
    _pyplot().close(fig)
    return path


def error_vs_step(table: list[dict], path: Path, title: str = "", axes: list[str] = ()) -> Path:
    plt = _pyplot()
    signals = [s for s in dict.fromkeys(r["signal"] for r in table) if s]
    cols = max(1, min(2, len(signals)))
    rows_n = max(1, math.ceil(len(signals) / cols))
    fig, grid = plt.subplots(rows_n, cols, figsize=(6 * cols, 4.8 * rows_n + 0.8), squeeze=False)
    schemes = list(_series(table, axes))
    for ax, signal in zip(grid.flat, signals):
        anchors = []
        for j, (label, rows) in enumerate(_series([r for r in table if r["signal"] == signal], axes).items()):
            rows = _finite(rows, "error_max")
            if rows:
                ax.loglog([r["step"] for r in rows], [r["error_max"] for r in rows], label=label, **_style(j))
                anchors.append((rows[-1]["step"], rows[-1]["error_max"]))
        if anchors:
            # reference slopes through the geometric mean of the errors at the largest step
            h0 = max(h for h, _ in anchors)
            e0 = math.exp(np.mean([math.log(e) for h, e in anchors if h == h0]))
            steps = sorted({r["step"] for r in table})
            hs = np.array([steps[0], h0])
            for p, style in ((1, "k--"), (2, "k:")):
                ax.loglog(hs, e0 * (hs / h0) ** p, style, lw=0.8, label=f"order {p}")
        ax.set_xlabel("step h [s]")
        ax.set_ylabel(f"max |error| of {signal}")
        ax.set_title(signal, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        _log_ticks(ax)
        _step_ticks(ax, sorted({r["step"] for r in table}))
        ax.legend(fontsize=7)
    for ax in list(grid.flat)[len(signals):]:
        ax.set_visible(False)
    _title(fig, f"error against step: {title}", schemes)
    return _save(fig, path)


def _per_run(table: list[dict], axes) -> list[dict]:
    """One row per run: the largest error over its signals."""
    per_run = {}
    for r in table:
        key = (r["algorithm"], r["extrapolation"], r["step"], *(repr(r.get(a)) for a in axes))
        e = r["error_max"]
        if isinstance(e, float) and math.isfinite(e):
            per_run[key] = {**r, "error_max": max(e, per_run.get(key, {}).get("error_max", 0.0))}
    return list(per_run.values())


def work_precision(table: list[dict], path: Path, title: str = "", axes: list[str] = ()) -> Path:
    """Error (the largest over the signals) against DoStep calls, one line per algorithm and settings."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 5.3))
    series = _series(_per_run(table, axes), axes)
    for j, (label, rows) in enumerate(series.items()):
        rows = [r for r in _finite(rows, "error_max") if r["fmu_calls"]]
        if rows:
            rows.sort(key=lambda r: r["fmu_calls"])
            ax.loglog([r["fmu_calls"] for r in rows], [r["error_max"] for r in rows], label=label, **_style(j))
    ax.set_xlabel("FMU DoStep calls")
    ax.set_ylabel("max |error| (largest over the signals)")
    ax.grid(True, which="both", alpha=0.3)
    _log_ticks(ax)
    ax.legend(fontsize=7)
    _title(fig, f"work against precision: {title}", list(series))
    return _save(fig, path)


def error_vs_setting(table: list[dict], path: Path, title: str = "", axes: list[str] = ()) -> Path | None:
    """Error (largest over the signals) against the first tolerance swept, one line per algorithm, other
    settings and step; None when no tolerance is swept over two values or more."""
    swept = [a for a in axes if a in TOLERANCES and len({r.get(a) for r in table if r.get(a) is not None}) > 1]
    if not swept:
        return None
    tol = swept[0]
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 5.3))
    rows = [r for r in _per_run(table, axes) if r.get(tol) is not None]
    series = {}
    for r in rows:
        series.setdefault(series_label(r, [a for a in axes if a != tol]) + f", h={r['step']:g}", []).append(r)
    for j, (label, rs) in enumerate(series.items()):
        rs = sorted(_finite(rs, "error_max"), key=lambda r: r[tol])
        if rs:
            ax.loglog([r[tol] for r in rs], [r["error_max"] for r in rs], label=label, **_style(j))
    ax.set_xlabel(tol)
    ax.set_ylabel("max |error| (largest over the signals)")
    ax.grid(True, which="both", alpha=0.3)
    _log_ticks(ax)
    ax.legend(fontsize=7)
    _title(fig, f"error against {tol}: {title}", list(series))
    return _save(fig, path)


def energy_residual(frames: dict[str, object], path: Path, title: str = "") -> Path | None:
    """The energy residual over time of every run that records one; None when no run does."""
    curves = [(label, df["time"].to_numpy(), df[c].to_numpy(dtype=float), c)
              for label, df in frames.items() for c in df.columns if str(c).endswith(ENERGY_RESIDUAL_SUFFIX)]
    if not curves:
        return None
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for j, (label, t, y, column) in enumerate(curves):
        ax.plot(t, y, linestyle=LINESTYLES[j % len(LINESTYLES)], label=f"{label}: {column}")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("energy residual")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    _title(fig, f"energy residual: {title}", sorted({label for label, *_ in curves}))
    return _save(fig, path)
