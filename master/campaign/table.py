"""The tidy results table of a campaign, rebuilt from its run records.

One row per run, or, when the campaign's scenario kind splits run summaries into members
(``ScenarioKind.summary_rows``; the UAV study: one row per UAV), one row per run and member plus the run's
total, the member named in the kind's ``member_column``; a run without such a summary (a run that crashed
before its monitor could write one) has a single row with the member empty.  Columns, in order:

``run_id``, the campaign's parameters (one column per grid/runs key, named as in the campaign file),
``rep``, ``seed``, ``run_outcome`` (completed / failed), ``error``, ``wall_time_s``,
``scenario_sha256``, the member column, then every metric of the member rows flattened (lists become
space-separated strings, mappings ``key.sub``), and, for kinds that record them,
``final:<component.variable>`` (last recorded value).  A metric whose name clashes with one of the
columns above is prefixed ``summary.``.

Rows follow the campaign's run order (the order of campaign.json) and, within a run, the member order then
the total: the table depends only on the set of records, never on the order in which they finished.
Only records that belong to the current campaign definition and whose input fingerprint matches it are
included (stale records are left on disk but never mixed in).
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from ..scenario_kinds import SCENARIO_KINDS

__all__ = ["load_manifest", "load_records", "records_table", "build_table", "write_table", "FIXED_COLUMNS"]

FIXED_COLUMNS = ["run_id", "rep", "seed", "run_outcome", "error", "wall_time_s", "scenario_sha256"]


def load_manifest(campaign_dir) -> dict:
    p = Path(campaign_dir) / "campaign.json"
    return json.loads(p.read_text(encoding="utf-8"))


def read_record(path: Path) -> dict | None:
    try:
        rec = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return rec if isinstance(rec, dict) and "run_id" in rec else None


def load_records(campaign_dir, manifest: dict | None = None) -> list[dict]:
    """The current, valid records of a campaign, in run order."""
    campaign_dir = Path(campaign_dir)
    manifest = manifest or load_manifest(campaign_dir)
    out = []
    for r in manifest["runs"]:
        rec = read_record(campaign_dir / "runs" / f"{r['run_id']}.json")
        if rec is None or rec.get("inputs_sha256") != r["inputs_sha256"]:
            continue
        if rec.get("outcome") not in ("completed", "failed"):
            continue
        out.append(rec)
    return out


def _flat(prefix: str, v, out: dict):
    if isinstance(v, dict):
        for k, x in v.items():
            _flat(f"{prefix}.{k}" if prefix else str(k), x, out)
    elif isinstance(v, (list, tuple)):
        out[prefix] = " ".join(str(x) for x in v)
    else:
        out[prefix] = v


def _member_columns(kind) -> list[str]:
    return [kind.member_column] if kind.member_column else []


def record_rows(rec: dict, param_keys: list, kind) -> list[dict]:
    """The table rows of one record (see the module docstring); ``kind``: the campaign's scenario kind."""
    members = _member_columns(kind)
    reserved = set(FIXED_COLUMNS) | set(members) | set(param_keys)
    base = {"run_id": rec["run_id"]}
    for k in param_keys:
        base[k] = rec.get("params", {}).get(k)
    base.update({"rep": rec.get("rep"), "seed": rec.get("seed"), "run_outcome": rec.get("outcome"),
                 "error": rec.get("error"), "wall_time_s": rec.get("wall_time_s"),
                 "scenario_sha256": rec.get("scenario_sha256")})

    def metrics(d: dict) -> dict:
        flat: dict = {}
        _flat("", d, flat)
        return {(f"summary.{k}" if k in reserved else k): v for k, v in flat.items()}

    final = rec.get("final") or {}
    extra = {f"final:{k}": v for k, v in final.items()}
    split = kind.summary_rows(rec.get("summary")) if members else []
    rows = []
    for member, values in split:
        row = dict(base)
        row[members[0]] = member
        row.update(metrics(values))
        rows.append(row)
    if not rows:
        row = dict(base)
        row.update({c: None for c in members})
        rows.append(row)
    rows[-1].update(extra)          # the run's own values go with its total
    return rows


def records_table(records: list[dict], param_keys: list, kind):
    """A pandas DataFrame of records (in the given order)."""
    import pandas as pd
    rows = [row for rec in records for row in record_rows(rec, param_keys, kind)]
    cols: list[str] = ["run_id", *param_keys, *FIXED_COLUMNS[1:], *_member_columns(kind)]
    seen = set(cols)
    for row in rows:
        for k in row:
            if k not in seen:
                seen.add(k)
                cols.append(k)
    df = pd.DataFrame(rows, columns=cols)
    for c in df.columns:
        if df[c].dtype == object:
            vals = df[c].dropna()
            if len(vals) and all(isinstance(v, bool) for v in vals):
                df[c] = df[c].astype("boolean")
            elif len(vals) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
                df[c] = pd.to_numeric(df[c])
            elif len(vals) and not all(isinstance(v, str) for v in vals):
                df[c] = df[c].map(lambda v: None if v is None else str(v))
    for c in ("rep", "seed"):
        if c in df.columns and len(df):
            df[c] = df[c].astype("int64")
    return df


def build_table(campaign_dir, manifest: dict | None = None, records: list[dict] | None = None):
    """``manifest``, ``records``: campaign.json's content and ``load_records``' answer when the caller has just
    read them (a campaign's last step: its final plan read every record already)."""
    manifest = manifest or load_manifest(campaign_dir)
    kind = SCENARIO_KINDS.get(manifest["kind"], element=str(Path(campaign_dir) / "campaign.json"))
    if records is None:
        records = load_records(campaign_dir, manifest)
    return records_table(records, manifest["param_keys"], kind)


def write_table(campaign_dir, manifest: dict | None = None, records: list[dict] | None = None) -> Path:
    """Rebuild results.parquet and results.csv from runs/*.json (atomic replace); returns the parquet path.
    ``manifest``, ``records``: see :func:`build_table`."""
    campaign_dir = Path(campaign_dir)
    df = build_table(campaign_dir, manifest, records)
    pq_path = campaign_dir / "results.parquet"
    csv_path = campaign_dir / "results.csv"
    tmp = campaign_dir / f".results.parquet.tmp{os.getpid()}"
    df.to_parquet(tmp, index=False)
    os.replace(tmp, pq_path)
    tmp = campaign_dir / f".results.csv.tmp{os.getpid()}"
    df.to_csv(tmp, index=False)
    os.replace(tmp, csv_path)
    return pq_path
