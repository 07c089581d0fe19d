"""Campaigns: many runs of one scenario over a parameter grid, resumable, on local processes or Dask.

* :mod:`.spec` -- campaign files read and validated into runs;
* :mod:`.identity` -- run ids, seeds, input fingerprints; :mod:`.design` -- the grid and ``design:``;
  :mod:`.options` -- run options;
* :mod:`.execute` -- one run as a worker executes it (returns its record);
* :mod:`.pool` -- long-lived worker processes that survive crashing FMUs;
* :mod:`.runner` -- ``run_campaign``: resume, stale detection, progress, Dask;
* :mod:`.table` -- the tidy results table rebuilt from the records;
* :mod:`.stats`, :mod:`.report` -- intervals, tests, figures and report.md.

See docs/campaigns.md.
"""
