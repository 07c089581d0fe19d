"""The paper's Figures 5-10 drawn from :func:`.statistics.figure_data`: each bar or point with its 95 % interval
and each panel with its n.  Matplotlib is imported only here, and only when a report is drawn.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .tables import area_label, is_zone
from .text import n_text

__all__ = ["COLORS", "draw_figures"]

#: the strategies' colours, as in the paper's figures
COLORS = {"A": "tab:blue", "B": "tab:red"}


def _figure(w=7.5, h=4.5, ncols=1):
    """A figure on the Agg canvas (no display, no global pyplot state) and its axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=(w, h), dpi=90)
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(1, ncols, i + 1) for i in range(ncols)]
    return fig, (axes[0] if ncols == 1 else axes)


def _error_bar(ci, scale: float = 1.0):
    """Matplotlib's yerr of an interval; None without one (fewer than 2 layouts: no bar at all, never a
    zero-width one)."""
    if not math.isfinite(ci.low) or not math.isfinite(ci.estimate):
        return None
    return [[max(0.0, (ci.estimate - ci.low) * scale)], [max(0.0, (ci.high - ci.estimate) * scale)]]


def _interval(ax, x, ci, **kw) -> None:
    """The 95 % interval of ``ci`` at x, when it has one."""
    yerr = _error_bar(ci)
    if yerr is not None:
        ax.errorbar(x, ci.estimate, yerr=yerr, fmt="none", ecolor="black", **kw)


def _wind_colors(winds):
    from matplotlib.colors import LinearSegmentedColormap
    cmap = LinearSegmentedColormap.from_list("paper_wind", ["#08306b", "#2171b5", "#41b6c4", "#41ab5d", "#00441b"])
    n = max(1, len(winds) - 1)
    return {w: cmap(i / n) for i, w in enumerate(winds)}


def _note(ax, text: str, below: float = 42) -> None:
    """n of the panel, ``below`` points under the axis (clear of its tick labels and x-axis label)."""
    ax.annotate(text, (0.5, 0.0), xycoords="axes fraction", xytext=(0, -below), textcoords="offset points",
                ha="center", va="top", fontsize=7, color="dimgray", annotation_clip=False)


def _headroom_legend(ax, n: int, top: float | None = None) -> None:
    """The wind-probability legend in one row above the bars, never over them: room made above the bars, or,
    with a fixed ``top`` (a percentage axis ends at 100 %), the legend outside the axes, under the title."""
    if top is None:
        low, high = ax.get_ylim()
        ax.set_ylim(low, high + 0.22 * (high - low))
        ax.legend(title="wind probability", fontsize=7, title_fontsize=7, ncol=n, loc="upper center",
                  columnspacing=0.8, handlelength=1.2)
        return
    ax.set_ylim(0.0, top)
    ax.legend(title="wind probability", fontsize=7, title_fontsize=7, ncol=n, loc="lower center",
              bbox_to_anchor=(0.5, 1.0), columnspacing=0.8, handlelength=1.2, frameon=False)


def _strategy_legend(ax, n: int) -> None:
    """The strategies' legend in one row between the title and an axis that ends at 100 %, never over a bar."""
    ax.legend(ncol=n, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False, fontsize=8)


def _pairs_note(effects: dict) -> str:
    """The n of a panel of paired differences: the layouts behind each point."""
    n = sorted({e.n for e in effects.values()})
    if not n:
        return "one wind probability: no pairs"
    shown = f"{n[0]}" if len(n) == 1 else f"{n[0]}-{n[-1]}"
    return (f"n = {shown} layouts per point (each the mean of its pairs: a run at w and the run of the same "
            "configuration and layout at 0 %)")


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path)
    return path


def _strategy_bars(ax, cis: dict, strategies, groups, width: float) -> None:
    """Side by side in each group, one bar per strategy with its interval (Figs. 6, 9 and 10)."""
    for i, s in enumerate(strategies):
        for j, g in enumerate(groups):
            ci = cis[(s, g)]
            x = j + (i - (len(strategies) - 1) / 2) * width
            ax.bar(x, ci.estimate if ci.n else 0, width, color=COLORS.get(s, f"C{i}"),
                   label=f"Strategy {s}" if j == 0 else None)
            if ci.n:
                _interval(ax, x, ci, capsize=3)


def _effect_lines(ax, effects: dict, series, winds, label) -> None:
    """Within-configuration differences (vs 0 % wind) per wind probability, one line per series, each point at
    its own wind probability (no sideways offset: points at one x are one level); series differ by colour,
    line style and marker."""
    xs = [w for w in winds if w > 0]
    markers = "osD^v<>"
    for i, key in enumerate(series):
        es = [effects[(*key, w) if isinstance(key, tuple) else (key, w)] for w in xs]
        y = [e.estimate for e in es]
        lo = [e.estimate - e.low if math.isfinite(e.low) else 0.0 for e in es]
        hi = [e.high - e.estimate if math.isfinite(e.high) else 0.0 for e in es]
        ax.errorbar([x * 100 for x in xs], y, yerr=[lo, hi], marker=markers[i % len(markers)], ms=4, capsize=2,
                    lw=1, alpha=0.85, label=label(key),
                    color=COLORS.get(key[0] if isinstance(key, tuple) else key, f"C{i}"),
                    ls="-" if not isinstance(key, tuple) or not is_zone(key[1]) else "--")
    ax.set_xticks([x * 100 for x in xs])
    ax.axhline(0.0, color="gray", lw=0.8)
    ax.set_xlabel("wind probability [%]")


def draw_figures(fd: dict, out: Path, r=None) -> dict:
    """Draw Figs. 5-10 of ``fd`` (:func:`.statistics.figure_data`) into ``out``; figure key -> PNG path.  ``r``
    (the runs) gives Fig. 9 the n of each area's panel."""
    out.mkdir(parents=True, exist_ok=True)
    strategies, fleets, winds, areas = fd["strategies"], fd["fleets"], fd["winds"], fd["areas"]
    n_all = fd["n"]
    files = {}
    width = 0.8 / max(1, len(strategies))
    colors = _wind_colors(winds)
    # -- Fig. 5
    fig, ax = _figure()
    for i, s in enumerate(strategies):
        for j, n in enumerate(fleets):
            k, m, ci = fd["fig5"][(s, n)]
            x = j + (i - (len(strategies) - 1) / 2) * width
            ax.bar(x, ci.estimate if ci.n else 0, width, color=COLORS.get(s, f"C{i}"),
                   label=f"Strategy {s}" if j == 0 else None)
            if m:
                _interval(ax, x, ci, capsize=3)
    per3 = 3.0 / max(1, fd["layouts"])
    ax.set_xticks(np.arange(len(fleets)),
                  [f"{n}\n(of {fd['fig5'][(strategies[0], n)][1] * per3:.0f})" for n in fleets])
    ax.set_xlabel("UAVs in the fleet (maximum successes per three layouts)")
    ax.set_ylabel("successful UAV missions per three layouts")
    ax.set_title("Fig. 5 - successes per fleet size (95 % interval over layouts)")
    ax.legend()
    _note(ax, n_all, 56)
    files["fig5"] = _save(fig, out / "fig5_success_per_fleet_size.png")
    # -- Fig. 6
    fig, ax = _figure()
    _strategy_bars(ax, fd["fig6"], strategies, areas, width)
    ax.set_xticks(np.arange(len(areas)), [area_label(a) for a in areas])
    ax.set_xlabel("area")
    ax.set_ylabel("mean remaining battery per UAV [%]")
    ax.set_ylim(0.0, 100.0)
    ax.set_title("Fig. 6 - remaining battery per area (95 % interval over layouts)", pad=22)
    _strategy_legend(ax, len(strategies))
    _note(ax, n_all)
    files["fig6"] = _save(fig, out / "fig6_battery_per_area.png")
    # -- Fig. 7: levels, and the within-configuration differences to 0 % wind
    fig, (ax, bx) = _figure(12, 4.8, 2)
    groups = [(s, a) for s in strategies for a in areas]
    bar_width = 0.85 / max(1, len(winds))
    for g, (s, a) in enumerate(groups):
        for k, w in enumerate(winds):
            ci = fd["fig7"][(s, a, w)]
            x = g + (k - (len(winds) - 1) / 2) * bar_width
            ax.bar(x, ci.estimate if ci.n else 0, bar_width, color=colors[w],
                   label=f"{w * 100:g} %" if g == 0 else None)
            if ci.n:
                _interval(ax, x, ci, capsize=1.5, lw=0.8)
    ax.set_xticks(np.arange(len(groups)), [f"{s} / {area_label(a)}" for s, a in groups])
    ax.set_xlabel("strategy / area")
    ax.set_ylabel("mean remaining battery per UAV [%]")
    ax.set_title("Fig. 7a - remaining battery per wind probability", fontsize=10, pad=34)
    _headroom_legend(ax, len(winds), top=100.0)
    _note(ax, n_all)
    if fd["fig7b"]:
        _effect_lines(bx, fd["fig7b"], groups, winds, lambda k: f"{k[0]} / {area_label(k[1])}")
        bx.legend(fontsize=7)
    bx.set_ylabel("battery at w minus at 0 % [%-points]")
    bx.set_title("Fig. 7b - same configuration and layout, paired (95 % interval over layouts)", fontsize=10)
    _note(bx, _pairs_note(fd["fig7b"]))
    files["fig7"] = _save(fig, out / "fig7_battery_per_wind.png")
    # -- Fig. 8
    fig, (ax, bx) = _figure(12, 4.8, 2)
    for g, s in enumerate(strategies):
        for k, w in enumerate(winds):
            ci = fd["fig8"][(s, w)]
            x = g + (k - (len(winds) - 1) / 2) * bar_width
            ax.bar(x, ci.estimate, bar_width, color=colors[w], label=f"{w * 100:g} %" if g == 0 else None)
            _interval(ax, x, ci, capsize=1.5, lw=0.8)
    ax.set_xticks(np.arange(len(strategies)), [f"Strategy {s}" for s in strategies])
    ax.set_xlabel("strategy")
    ax.set_ylabel("total distance flown per three layouts [km]")
    ax.set_title("Fig. 8a - total distance per wind probability", fontsize=10)
    _headroom_legend(ax, len(winds))
    _note(ax, n_all)
    if fd["fig8b"]:
        _effect_lines(bx, fd["fig8b"], strategies, winds, lambda k: f"Strategy {k}")
        bx.legend(fontsize=7)
    bx.set_ylabel("distance per run at w minus at 0 % [km]")
    bx.set_title("Fig. 8b - same configuration and layout, paired (95 % interval over layouts)", fontsize=10)
    _note(bx, _pairs_note(fd["fig8b"]))
    files["fig8"] = _save(fig, out / "fig8_distance_per_wind.png")
    # -- Fig. 9, one panel per area, and the ratio the verdict tests
    fig, axes = _figure(5 * (len(areas) + 1), 4.5, len(areas) + 1)
    axes, rx = axes[:-1], axes[-1]
    kinds = [("uav", "UAV"), ("zone", "restricted area (wall)")]
    for ax, a in zip(axes, areas):
        _strategy_bars(ax, {(s, kind): fd["fig9"][(s, a, kind)] for s in strategies for kind, _ in kinds},
                       strategies, [kind for kind, _ in kinds], width)
        ax.set_xticks(np.arange(len(kinds)), [label for _, label in kinds])
        ax.set_xlabel("impact point")
        ax.set_ylabel("UAVs removed by a collision, per three layouts")
        ax.set_title(f"Fig. 9 - {area_label(a)} area (95 % interval)", fontsize=10)
        ax.legend()
        if r is not None:
            _note(ax, n_text(r[r["area"] == a]))
    rx.axhspan(2.0, 4.0, color="0.9", label="paper: 3 ± 1")
    rx.axhline(3.0, color="gray", lw=0.8)
    for i, s in enumerate(strategies):
        ci = fd["fig9_ratio"][s]
        if math.isfinite(ci.estimate):
            rx.plot([i], [ci.estimate], "o", color=COLORS.get(s, f"C{i}"), label=f"Strategy {s}")
            _interval(rx, i, ci, capsize=4)
    rx.set_xticks(np.arange(len(strategies)), [f"Strategy {s}" for s in strategies])
    rx.set_xlim(-0.6, len(strategies) - 0.4)
    rx.set_ylim(bottom=0.0)
    rx.set_ylabel("wall / UAV-UAV collisions (UAVs removed)")
    rx.set_title("Fig. 9 - the ratio tested (Fieller 95 % interval)", fontsize=10)
    rx.legend(fontsize=7)
    _note(rx, "both areas; " + n_all.split(",")[0])
    files["fig9"] = _save(fig, out / "fig9_collisions_per_impact.png")
    # -- Fig. 10
    fig, ax = _figure()
    _strategy_bars(ax, fd["fig10"], strategies, fleets, width)
    ax.set_xticks(np.arange(len(fleets)), [str(n) for n in fleets])
    ax.set_xlabel("UAVs in the fleet")
    ax.set_ylabel("mean remaining battery per UAV [%]")
    ax.set_ylim(0.0, 100.0)
    ax.set_title("Fig. 10 - remaining battery per fleet size (95 % interval over layouts)", pad=22)
    _strategy_legend(ax, len(strategies))
    _note(ax, n_all)
    files["fig10"] = _save(fig, out / "fig10_battery_per_fleet_size.png")
    return files
