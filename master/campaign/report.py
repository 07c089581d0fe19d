"""``build_report(dir)``: the markdown report (and figures) of a finished campaign.

The campaign's scenario kind (``master.scenario_kinds``, recorded in campaign.json) writes its own report
when it has one (the UAV study's reproduces the paper's figures and Table II); otherwise, and for plain SSP
campaigns, the report summarises the outcomes and the mean final values per parameter set, with 95 %
Student t intervals over the repetitions (``master.campaign.stats``).  The helpers below (markdown
tables, campaign facts, failed runs) are shared with the kinds' reports.
"""
from __future__ import annotations

import json
from pathlib import Path

from ..scenario_kinds import SCENARIO_KINDS
from . import stats as st
from .table import build_table, load_manifest

__all__ = ["build_report", "md_table", "campaign_facts", "failures_md", "fmt_duration"]


def md_table(header: list[str], rows: list[list]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    for r in rows:
        out.append("| " + " | ".join(str(x).replace("|", "\\|") for x in r) + " |")
    return "\n".join(out)


def fmt_duration(seconds: float) -> str:
    """A duration in the unit that shows it (a 3 s total is not "0.1 min")."""
    if seconds < 60:
        return f"{seconds:.1f} s"
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.2f} h"


def campaign_facts(manifest: dict, df) -> list[str]:
    runs = df.drop_duplicates("run_id")
    n_total = len(manifest["runs"])
    n_done = int((runs["run_outcome"] == "completed").sum())
    n_fail = int((runs["run_outcome"] == "failed").sum())
    opts = manifest.get("options") or {}
    facts = [f"Campaign `{manifest['name']}` ({manifest.get('description') or 'no description'}): "
             f"{n_total} runs defined, {n_done} completed, {n_fail} failed, {n_total - n_done - n_fail} not run.",
             f"Campaign seed {manifest['seed']}, {manifest['repetitions']} repetition(s) per parameter set; "
             f"run options: {json.dumps(opts, sort_keys=True)}.",
             f"Parameters: {', '.join(manifest['param_keys']) or '(none)'}."]
    if "wall_time_s" in runs.columns and len(runs):
        w = runs["wall_time_s"].astype(float)
        facts.append(f"Run wall time: mean {w.mean():.2f} s, max {w.max():.2f} s, sum {fmt_duration(w.sum())}.")
    return facts


def failures_md(df) -> str:
    runs = df.drop_duplicates("run_id")
    fails = runs[runs["run_outcome"] == "failed"]
    if fails.empty:
        return "No run failed.\n"
    rows = [[r["run_id"], r.get("error")] for _, r in fails.head(50).iterrows()]
    return md_table(["run", "error"], rows) + ("\n\n(first 50 shown)\n" if len(fails) > 50 else "\n")


def _generic_report(manifest, df) -> str:
    L = [f"# Campaign report: {manifest['name']}", ""]
    L += [f"- {x}" for x in campaign_facts(manifest, df)]
    L += ["", "Values: mean [95 % Student t interval] over repetitions of each parameter set (completed runs).", ""]
    keys = [k for k in manifest["param_keys"] if k in df.columns]
    finals = [c for c in df.columns if c.startswith("final:") and c != "final:time"]
    done = df[df["run_outcome"] == "completed"]
    if finals and len(done):
        grp = done.groupby(keys, dropna=False, sort=False) if keys else [((), done)]
        rows = []
        for key, sub in grp:
            key = key if isinstance(key, tuple) else (key,)
            rows.append([*key, len(sub), *[st.mean_ci(sub[c]).fmt(4) for c in finals]])
        L += [md_table([*keys, "runs", *finals], rows), ""]
    L += ["## Failed runs", "", failures_md(df)]
    return "\n".join(L)



def build_report(campaign_dir, progress: bool = False) -> Path:
    """Write ``<dir>/report/report.md`` (and the figures next to it) from the campaign's records; ``progress``:
    a bar on stderr naming the step under way (reading the records, the kind's figures and tables, writing)."""
    campaign_dir = Path(campaign_dir)
    if not (campaign_dir / "campaign.json").is_file():
        from ..errors import CosimError
        raise CosimError("not a campaign folder (no campaign.json); run 'cosim-master campaign' first",
                         file=str(campaign_dir))
    manifest = load_manifest(campaign_dir)
    kind = SCENARIO_KINDS.get(manifest["kind"], element=str(campaign_dir / "campaign.json"))
    with _Steps(progress, manifest["name"]) as steps:
        steps.next(f"reading {len(manifest['runs'])} records")
        df = build_table(campaign_dir)
        out = campaign_dir / "report"
        out.mkdir(exist_ok=True)
        steps.next("figures and tables")
        text = kind.report(manifest, df, out) if len(df) else None
        if text is None:
            text = _generic_report(manifest, df)
        steps.next("writing report.md")
        path = out / "report.md"
        tmp = out / ".report.md.tmp"
        tmp.write_text(text + "\n", encoding="utf-8")
        tmp.replace(path)
        steps.next("done")
    return path


class _Steps:
    """A bar of the report's steps whose elapsed time keeps moving while a long step (the figures) runs: the
    kind's report gives no finer measure of progress."""
    N = 3

    def __init__(self, enabled: bool, name: str):
        self.bar = None
        if enabled:
            from tqdm import tqdm
            self.bar = tqdm(total=self.N, desc=f"report {name}", unit="step", dynamic_ncols=True,
                            bar_format="{desc}: {n_fmt}/{total_fmt} steps |{bar}| {elapsed} {postfix}")
        self.started = 0

    def next(self, what: str) -> None:
        if self.bar is None:
            return
        if self.started:
            self.bar.update(1)
        self.started += 1
        self.bar.set_postfix_str(what)

    def __enter__(self):
        if self.bar is not None:
            import threading
            self._stop = threading.Event()

            def tick():
                while not self._stop.wait(0.5):
                    self.bar.refresh()
            self._ticker = threading.Thread(target=tick, name="cosim-report-progress", daemon=True)
            self._ticker.start()
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self._stop.set()
            self._ticker.join()
            self.bar.close()
        return False
