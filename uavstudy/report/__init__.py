"""The report of a UAV campaign: the paper's Figures 5-10 and Table II, our numbers next to the published ones,
and (for a campaign with a ``design:``) which factors flip each finding.

``cosim-master report`` calls :func:`uav_report` through the ``uav`` scenario kind (``uavstudy.campaign_kind``)
for a campaign whose table has per-UAV rows.  The parts, in the order the data flows through them:

* :mod:`.paper_values` -- the paper's published numbers with the sentences they are quoted from, the tolerances
  around them, and which of them cannot all hold together;
* :mod:`.tables` -- the results table shaped for the analysis: missions and runs, configuration, cell, block;
* :mod:`.settings` -- what the runs flew with, and the causes of a difference stated from it;
* :mod:`.statistics` -- every interval, paired difference, slope and ratio, with the layout as the unit (one
  value per layout, then a t interval and t-test over layouts; reusable for other strategies' campaigns);
* :mod:`.findings` -- the verdicts by one rule fixed before the data (yes / reversed / not shown; magnitude
  within / outside), the declared collision count, Table II's "better", the statements a design's
  configurations move or flip;
* :mod:`.figures` -- the figures; :mod:`.text` -- how numbers are written; :mod:`.markdown` -- report.md.
"""
from __future__ import annotations

from .figures import COLORS, draw_figures
from .findings import (COLLISION_RULE, MIN_LAYOUTS, NOT_SHOWN, REVERSED, TABLE2, YES, Magnitude, Part, combine,
                       direction_verdict, finding_rows, paper_comparison, sensitivity_findings, table2, too_small,
                       verdict_text)
from .markdown import sensitivity_md, uav_report
from .paper_values import PAPER, PAPER_MISSIONS, PAPER_REPETITIONS, PAPER_VALUES, paper_consistency
from .settings import causes, run_settings, settings_summary
from .statistics import (NO_CI, ab_effect, area_effect, by_layout, figure_data, fleet_slope, fleet_step, level_ci,
                         n_layouts, paper_grid_total, per_mission_total, ratio_ci, wind_effect, wind_slope)
from .tables import STUDY_AXES, area_label, pair_keys, param_columns, uav_frames
from .text import ci_text, n_text, num, p_text, ratio_text

__all__ = ["uav_report", "uav_frames", "figure_data", "table2", "paper_comparison", "pair_keys", "PAPER",
           "paper_consistency", "sensitivity_findings", "run_settings", "finding_rows", "too_small",
           "PAPER_VALUES", "PAPER_MISSIONS", "PAPER_REPETITIONS", "STUDY_AXES", "TABLE2", "COLORS", "NO_CI",
           "param_columns", "area_label", "settings_summary", "causes", "level_ci", "paper_grid_total",
           "per_mission_total", "ab_effect", "wind_effect", "wind_slope", "area_effect", "fleet_step", "fleet_slope",
           "ratio_ci", "by_layout", "n_layouts", "verdict_text", "Part", "Magnitude", "direction_verdict", "combine",
           "COLLISION_RULE", "MIN_LAYOUTS", "YES", "REVERSED", "NOT_SHOWN", "sensitivity_md", "draw_figures",
           "ci_text", "n_text", "num", "p_text", "ratio_text"]
