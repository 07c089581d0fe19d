"""The report of a UAV campaign: the paper's Figures 5-10 and Table II, our numbers next to the published ones,
and (for a campaign with a ``design:``) which factors flip each finding.

``cosim-master report`` calls :func:`uav_report` through the ``uav`` scenario kind (``uavstudy.campaign_kind``)
for a campaign whose table has per-UAV rows.  The parts, in the order the data flows through them:

* :mod:`.paper_values` -- the paper's published numbers with the sentences they are quoted from, the tolerances
  around them, and which of them cannot all hold together;
* :mod:`.tables` -- the results table shaped for the analysis: missions and runs, configuration, cell, block;
* :mod:`.settings` -- what the runs flew with, and the causes of a difference stated from it;
* :mod:`.statistics` -- every interval, paired difference and slope (the run is the unit, blocks are paired,
  intervals stratified by configuration);
* :mod:`.findings` -- the verdicts: Table II's "better", each published claim reproduced or not, the findings
  a design's configurations flip;
* :mod:`.figures` -- the figures; :mod:`.text` -- how numbers are written; :mod:`.markdown` -- report.md.
"""
from __future__ import annotations

from .figures import COLORS, draw_figures
from .findings import TABLE2, flip_kind, paper_comparison, sensitivity_findings, table2, verdict_text
from .markdown import sensitivity_md, uav_report
from .paper_values import PAPER, PAPER_MISSIONS, PAPER_VALUES, paper_consistency
from .settings import causes, run_settings, settings_summary
from .statistics import (NO_CI, ab_effect, area_effect, battery_ci, figure_data, fleet_slope, level_ci, per_layout,
                         total_ci, wind_effect, wind_slope)
from .tables import STUDY_AXES, area_label, pair_keys, param_columns, uav_frames
from .text import effect_text, n_text, p_text, ratio_text

__all__ = ["uav_report", "uav_frames", "figure_data", "table2", "paper_comparison", "pair_keys", "PAPER",
           "paper_consistency", "sensitivity_findings", "run_settings",
           "PAPER_VALUES", "PAPER_MISSIONS", "STUDY_AXES", "TABLE2", "COLORS", "NO_CI", "param_columns",
           "area_label", "settings_summary", "causes", "battery_ci", "level_ci", "total_ci", "per_layout",
           "ab_effect", "wind_effect", "wind_slope", "area_effect", "fleet_slope", "flip_kind", "verdict_text",
           "sensitivity_md", "draw_figures", "effect_text", "n_text", "p_text", "ratio_text"]
