"""The campaign's table is built from the records its final plan read (``runner.table_records``) instead of reading
every record again: the same records, hence the same table, as ``table.load_records`` reading them from disk, with
stale, unreadable, foreign, missing and interrupted records among them."""
import json

import pandas as pd

from campaign_helpers import write_chain_ssp
from master.campaign.runner import plan_campaign, table_records
from master.campaign.spec import load_campaign
from master.campaign.table import build_table, load_records

CAMPAIGN = """\
name: chain
seed: 5
repetitions: 3
scenario: chain.ssp
grid:
  param:gain.k: [1.0, 2.0, 3.0]
run:
  stop_time: 1.0
  step: 0.1
"""


def _record(r, fingerprint, outcome, k):
    return {"format": 1, "campaign": "chain", "run_id": r.run_id, "index": r.index, "params": r.params, "rep": r.rep,
            "seed": r.seed, "outcome": outcome, "error": None if outcome == "completed" else f"why {k}",
            "wall_time_s": 0.1 * k, "inputs_sha256": fingerprint, "scenario_sha256": "x",
            "final": {"gain.y": 1.5 * k, "integ.y": float(k), "ok": k % 2 == 0}}


def test_table_records_are_what_load_records_reads(tmp_path, chain_fmus):
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    (tmp_path / "campaign.yaml").write_text(CAMPAIGN)
    camp = load_campaign(tmp_path / "campaign.yaml")
    out = tmp_path / "out"
    (out / "runs").mkdir(parents=True)
    manifest = camp.manifest()
    (out / "campaign.json").write_text(json.dumps(manifest, indent=1))
    fingerprints = {r["run_id"]: r["inputs_sha256"] for r in manifest["runs"]}
    kinds = ["completed", "failed", "interrupted", "stale", "unreadable", "missing", "completed", "failed",
             "completed"]
    assert len(camp.runs) == len(kinds)
    for k, (r, what) in enumerate(zip(reversed(camp.runs), kinds)):   # not in run order on disk
        p = out / "runs" / f"{r.run_id}.json"
        if what == "missing":
            continue
        if what == "unreadable":
            p.write_text('{"run_id": "' + r.run_id + '", "outcome": "compl')
            continue
        fp = "an-old-fingerprint" if what == "stale" else fingerprints[r.run_id]
        p.write_text(json.dumps(_record(r, fp, "completed" if what == "stale" else what, k), indent=1))
    (out / "runs" / "0123456789ab.json").write_text(json.dumps(_record(camp.runs[0], "x", "completed", 99)))

    done, todo, s = plan_campaign(camp, out, False, fingerprints)
    records = table_records(done)
    assert records == load_records(out)
    assert [rec["outcome"] for rec in records] == ["completed", "failed", "completed", "failed", "completed"]
    assert [rec["run_id"] for rec in records] == [r["run_id"] for r in manifest["runs"]
                                                  if any(rec["run_id"] == r["run_id"] for rec in records)]
    pd.testing.assert_frame_equal(build_table(out, manifest, records), build_table(out))
    assert len(build_table(out)) == 5
