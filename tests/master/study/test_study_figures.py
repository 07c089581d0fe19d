"""The study's figures (issue 28): every figure's title names the scenario, the reference and the schemes; every
series has its own marker and line style (Gauss-Seidel K = 1 and K = 2 lie on top of each other on the
oscillator: both must stay visible); tick labels do not overlap. Read from the matplotlib figures themselves."""
import itertools
from pathlib import Path

from master.study import figures, run_study

REPO = Path(__file__).resolve().parents[3]
COUPLING = REPO / "ssp" / "coupling"
EXACT = COUPLING / "oscillator_exact.py"


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_figures_name_scenario_reference_and_schemes_with_distinct_styles(tmp_path, monkeypatch):
    saved = {}
    save = figures._save

    def keep(fig, path):
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        ticks = [[t.get_window_extent(renderer) for t in ax.get_xticklabels() + ax.get_yticklabels()
                  if t.get_visible() and t.get_text()] for ax in fig.axes if ax.get_visible()]
        lines = [[(ln.get_marker(), str(ln.get_linestyle()), ln.get_label()) for ln in ax.get_lines()
                  if not ln.get_label().startswith("order")] for ax in fig.axes if ax.get_visible()]
        saved[Path(path).name] = (fig._suptitle.get_text() if fig._suptitle else "", ticks, lines)
        return save(fig, path)
    monkeypatch.setattr(figures, "_save", keep)
    out = tmp_path / "s"
    s = run_study(COUPLING / "oscillator_fd.ssp", algorithms=["jacobi", "gauss-seidel"], extrapolations=[0, 1, 2],
                  steps=[0.04, 0.02, 0.01, 0.005], reference=f"analytic:{EXACT}:fd", record=["A.x", "B.x"],
                  output=out, workers=1, progress=False, stop_time=2.0)
    assert {p.name for p in s.figures} == {"error_vs_step.png", "work_precision.png"} == set(saved)
    for name, (title, ticks, lines) in saved.items():
        flat = " ".join(title.split())
        assert "oscillator_fd.ssp" in flat and f"analytic:{EXACT}:fd (closed form)".replace(" ", "") in \
            flat.replace(" ", "")
        for scheme in ("jacobi", "jacobi, K=1", "jacobi, K=2", "gauss-seidel", "gauss-seidel, K=1",
                       "gauss-seidel, K=2"):
            assert scheme in flat
        for panel in ticks:
            assert not any(_overlap(a, b) for a, b in itertools.combinations(panel, 2)), name
        for panel in lines:
            assert len(panel) == 6
            assert len({(m, ls) for m, ls, _ in panel}) == 6 and len({m for m, _, _ in panel}) == 6
