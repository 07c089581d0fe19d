"""The report of a UAV campaign: the paper's Figures 5-10 and Table II, and our numbers next to the published ones.

``cosim-master report`` calls :func:`uav_report` through the ``uav`` scenario kind (``uavstudy.campaign_kind``)
for a campaign whose table has per-UAV rows; the markdown helpers are the generic report's
(``master.campaign.report``).

Statistics (``master.campaign.stats``; 95 % two-sided everywhere):

* success counts: Wilson score interval of the proportion, scaled to counts; A vs B: Fisher's exact test;
* means (remaining battery per UAV): Student t interval;
* totals over runs (distance, collisions, photos): n x the t interval of the per-run mean;
* intervals of quantities that cannot be negative are truncated at 0, of percentages also at 100, and of
  UAVs removed by collisions at the number of UAVs that flew;
* A vs B on per-run / per-UAV metrics: two-sided Mann-Whitney U;
* trends (battery or distance vs wind probability, battery vs fleet size): least-squares slope with
  its t interval.

Unit of analysis: one UAV mission for success and remaining battery (the paper counts successes out of
42/84/126/168 = UAV missions per fleet size), one run for distance, photos and collisions (the paper
sums them).  Only runs that completed are analysed; failed runs are listed.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from master.campaign import stats as st
from master.campaign.report import campaign_facts, failures_md, md_table
from master.campaign.spec import canonical_json

from .names import TOTAL_ROW, UAV_COLLISION, UAV_COLUMN, ZONE_COLLISION

__all__ = ["uav_report", "uav_frames", "figure_data", "table2", "paper_comparison", "pair_keys", "PAPER"]

COLORS = {"A": "tab:blue", "B": "tab:red"}

#: the published numbers, quoted from the paper (section V)
PAPER = {
    "runs": ("336", "\"... for each possibility of wind occurrence, three simulations were performed, which "
                    "resulted in a total of 336 simulations.\""),
    "max_success": ("42, 84, 126, 168", "\"The maximum number of successes that could be obtained for the strategy "
                                        "simulations with 1, 2, 3 and 4 UAVs, respectively, were 42, 84, 126, 168.\""),
    "success_1": ("0 (A), 0 (B)", "\"It can be noted that using only 1 UAV was unsuccessful ...\""),
    "success_2": ("0 (A), > 0 (B)", "\"... and with 2 UAVs only success by strategy B.\""),
    "success_dir": ("B > A", "\"... it can be noted that strategy B was superior to strategy A.\""),
    "battery_total": ("41.07 % (A), 41.83 % (B)", "\"... the total remaining battery of the drones that used "
                                                  "Strategy B was 41.83%, against 41.07% of Strategy A.\""),
    "battery_area": ("A > B in both areas", "\"It can be observed that Strategy A, characterized by the blue color, "
                                            "was superior to Strategy B.\" (Fig. 6)"),
    "battery_wind": ("decreases with wind", "\"... the consumption increases with higher probabilities of wind "
                                            "because the drones correct their trajectories ...\" (Fig. 7)"),
    "battery_zones": ("zones > free", "\"Low battery consumption in restricted areas is justified by the high rate "
                                      "of collisions in these areas ...\""),
    "distance_total": ("~270 km (A), ~240 km (B)", "\"Strategy B was superior in this metric, with a total distance "
                                                   "traveled was about 240km. Strategy A was about 270km ...\""),
    "distance_zones": ("zones < free", "\"... in restricted areas, the distances traveled are smaller.\""),
    "distance_wind": ("increases with wind", "\"... with some exceptions, the higher the occurrence of wind, the "
                                             "greater its influence on the total distance of the flight course.\""),
    "collisions": ("215 (A), 181 (B)", "\"For this metric, Strategy A had 215 total collisions, while in Strategy B, "
                                       "there were 181.\""),
    "wall_ratio": ("zone ≈ 3 × UAV, both strategies", "\"... in the two strategies, the number of collisions occurred "
                                                      "in the wall is the triple of those between UAVs.\""),
    "battery_fleet": ("increases with fleet size, except A with 1 UAV",
                      "\"... the average of the remaining battery charge per quantity of UAVs tends to gradually "
                      "increase ... a notable exception ... Strategy A, when only one UAV was used.\" (Fig. 10)"),
    "table2": ("B better on all 8 metrics", "Table II marks Strategy A with x on every row and Strategy B with a "
                                            "check (the extracted text shows the symbols as •, ✓, /)."),
}

#: why a claim can come out differently here (used when ours disagrees)
WHY = {
    "geometry": "The paper publishes no coordinates: our 24 targets, base and 4 restricted zones are an assumed "
                "layout (ssp/scenarios/paper_area*.yaml, docs/paper_config_format.md); every absolute number "
                "(distances, battery, collision counts) depends on it.",
    "energy": "Our battery is a physical model (uavsim.battery: rotor power from airspeed and climb, Li-ion pack) "
              "instead of the paper's Ptolemy Energy actor, whose consumption law is not published.",
    "wind": "The paper's wind model is not published; ours draws wind in 1 s decision intervals with the given "
            "probability, weak/moderate/strong 3/6/9 m/s from the east, and the UAV controller corrects the drift.",
    "collisions_count": "The paper does not say whether a UAV-UAV collision counts once or once per UAV; we count "
                        "removed UAVs (a UAV-UAV collision removes two).",
    "collisions_model": "Our collision detection is continuous (swept) over each step; zone detection uses the "
                        "paper's 2 m look-ahead and the zone polygons of our assumed layout.",
    "success_def": "Success follows the paper: all assigned targets photographed, back at base with more than 5 % "
                   "battery; the 80 % return and 95 % forced-landing rules are applied by our strategy FMU.",
    "stochastic": "With 3 repetitions per cell the per-cell estimates are noisy; differences whose interval "
                  "contains zero (or p >= 0.05) are not evidence either way.",
}


# ============================================================================================ data
def _col(df, *names):
    for n in names:
        if n in df.columns:
            return n
    return None


def uav_frames(df):
    """(U, R): one row per UAV mission and one per run, completed runs only, with the analysis columns
    strategy, n_uavs, area, wind (probability, fraction)."""
    import pandas as pd
    df = df.copy()
    if UAV_COLUMN not in df.columns:
        return None, None
    done = df[df["run_outcome"] == "completed"]
    tot = done[done[UAV_COLUMN] == TOTAL_ROW].copy()
    uav = done[done[UAV_COLUMN].notna() & (done[UAV_COLUMN] != TOTAL_ROW)].copy()
    if tot.empty or uav.empty:
        return None, None
    scol = _col(tot, "strategy", "summary.strategy")
    ncol = _col(tot, "n_uavs", "uavs")
    acol = _col(tot, "variant", "scenario")
    wcol = _col(tot, "wind.probability", "wind_probability")
    runs = pd.DataFrame({"run_id": tot["run_id"].to_numpy(),
                         "strategy": tot[scol].astype(str).to_numpy() if scol else "?",
                         "n_uavs": pd.to_numeric(tot[ncol]).astype(int).to_numpy() if ncol else 0,
                         "area": tot[acol].astype(str).to_numpy() if acol else "all",
                         "wind": pd.to_numeric(tot[wcol]).astype(float).to_numpy() if wcol else 0.0})
    u = uav.merge(runs, on="run_id", how="inner", suffixes=("_param", ""))
    for c in ("strategy", "n_uavs", "area", "wind"):
        if c + "_param" in u.columns:
            u = u.drop(columns=[c + "_param"])
    u["success"] = u["success"].astype(bool) if "success" in u.columns else False
    u["remaining_battery_pct"] = pd.to_numeric(u.get("remaining_battery_pct"), errors="coerce")
    u["collision_uav"] = (u["outcome"] == UAV_COLLISION).astype(int)
    u["collision_zone"] = (u["outcome"] == ZONE_COLLISION).astype(int)
    agg = u.groupby("run_id").agg(uav_collided=("collision_uav", "sum"), zone_collided=("collision_zone", "sum"),
                                  successes=("success", "sum"),
                                  first_removal_s=("removed_time", lambda s: pd.to_numeric(s, errors="coerce").min()))
    r = runs.merge(agg, on="run_id", how="left")
    tot_idx = tot.set_index("run_id")
    # the run's totals are sums over its UAVs (summary.json names them *_sum)
    r["distance_m"] = pd.to_numeric(tot_idx.loc[r["run_id"], "distance_m_sum"]).to_numpy()
    r["photos"] = (pd.to_numeric(tot_idx.loc[r["run_id"], "photos_sum"]).to_numpy() if "photos_sum" in tot.columns
                   else np.nan)
    r["uav_collision_events"] = (pd.to_numeric(tot_idx.loc[r["run_id"], "uav_collisions"]).to_numpy()
                                 if "uav_collisions" in tot.columns else np.nan)
    r["collisions"] = r["uav_collided"] + r["zone_collided"]
    return u, r


def _areas(u):
    names = list(dict.fromkeys(u["area"]))
    return sorted(names, key=lambda a: ("zone" in a.lower() or "restrict" in a.lower(), a))


def battery_ci(values) -> st.CI:
    """Mean remaining battery with its t interval, cut to the percentages a battery can have."""
    return st.mean_ci(values, floor=0.0, ceiling=100.0)


def ratio_text(num: int, den: int) -> str:
    """num / den as "2.50×"; a zero denominator has no ratio ("both 0", or "n/a" beside a non-zero numerator)."""
    if den:
        return f"{num / den:.2f}×"
    return "both 0" if num == 0 else "n/a: none in the denominator"


def _is_zone(area: str) -> bool:
    return "zone" in area.lower() or "restrict" in area.lower()


def figure_data(u, r) -> dict:
    """Every number the figures show (estimates and 95 % intervals), keyed by figure."""
    strategies = sorted(set(u["strategy"]))
    fleets = sorted(set(int(x) for x in u["n_uavs"]))
    winds = sorted(set(float(x) for x in u["wind"]))
    areas = _areas(u)
    d: dict = {"strategies": strategies, "fleets": fleets, "winds": winds, "areas": areas}
    f5 = {}
    for s in strategies:
        for n in fleets:
            sub = u[(u["strategy"] == s) & (u["n_uavs"] == n)]
            k, m = int(sub["success"].sum()), len(sub)
            f5[(s, n)] = (k, m, st.wilson_ci(k, m))
    d["fig5"] = f5
    d["fig6"] = {(s, a): battery_ci(u[(u["strategy"] == s) & (u["area"] == a)]["remaining_battery_pct"])
                 for s in strategies for a in areas}
    d["fig7"] = {(s, a, w): battery_ci(u[(u["strategy"] == s) & (u["area"] == a) & (u["wind"] == w)]
                                       ["remaining_battery_pct"])
                 for s in strategies for a in areas for w in winds}
    d["fig8"] = {(s, w): st.total_ci(r[(r["strategy"] == s) & (r["wind"] == w)]["distance_m"] / 1000.0, floor=0.0)
                 for s in strategies for w in winds}
    # no more UAVs can be removed than flew in those runs
    d["fig9"] = {(s, kind): st.total_ci(r[r["strategy"] == s][col], floor=0.0,
                                        ceiling=float(r[r["strategy"] == s]["n_uavs"].sum()))
                 for s in strategies for kind, col in (("uav", "uav_collided"), ("zone", "zone_collided"))}
    d["fig10"] = {(s, n): battery_ci(u[(u["strategy"] == s) & (u["n_uavs"] == n)]["remaining_battery_pct"])
                  for s in strategies for n in fleets}
    return d


# ============================================================================================ table II
TABLE2 = [
    # key, label, level (uav | run), column, better, wind only
    ("success", "Success per number of UAVs", "uav", "success", "higher", False),
    ("photos", "Number of photos", "run", "photos", "higher", False),
    ("photos_wind", "Number of photos with wind", "run", "photos", "higher", True),
    ("energy", "Remaining energy", "uav", "remaining_battery_pct", "higher", False),
    ("energy_wind", "Remaining energy with wind", "uav", "remaining_battery_pct", "higher", True),
    ("distance", "Travelled distance", "run", "distance_m", "lower", False),
    ("distance_wind", "Travelled distance with wind", "run", "distance_m", "lower", True),
    ("collisions", "Number of collisions", "run", "collisions", "lower", False),
]


def pair_keys(df, manifest) -> dict | None:
    """run_id -> the key that matches a strategy-A run with its strategy-B twin (every other parameter and the
    repetition: the runs that share their seed in a campaign with ``paired: [strategy]``); None when the
    campaign is not paired on the strategy."""
    if "strategy" not in (manifest.get("paired") or []) or df is None or UAV_COLUMN not in df.columns:
        return None
    keys = [k for k in manifest.get("param_keys", []) if k != "strategy" and k in df.columns] + ["rep"]
    tot = df[df[UAV_COLUMN] == TOTAL_ROW]
    return {rid: canonical_json([_plain(v) for v in row])
            for rid, row in zip(tot["run_id"], tot[keys].itertuples(index=False))}


def _plain(v):
    return v.item() if hasattr(v, "item") else v


def _paired(data, col, level, pairs, success: bool):
    """(test, p, number of pairs, mean B - A) over the A/B twins of ``data`` (runs, or UAVs by name)."""
    d = data[data["run_id"].isin(list(pairs))].copy()
    d["_key"] = d["run_id"].map(pairs)
    if level == "uav":
        d["_key"] = d["_key"] + "/" + d[UAV_COLUMN].astype(str)
    a = d[d["strategy"] == "A"].drop_duplicates("_key").set_index("_key")[col]
    b = d[d["strategy"] == "B"].drop_duplicates("_key").set_index("_key")[col]
    common = a.index.intersection(b.index)
    a, b = a.loc[common], b.loc[common]
    if success:
        a, b = a.astype(bool), b.astype(bool)
        n10, n01 = int((a & ~b).sum()), int((~a & b).sum())
        return "McNemar exact", st.mcnemar_exact(n10, n01) if len(common) else math.nan, len(common), \
            float((b.astype(float) - a.astype(float)).mean()) if len(common) else math.nan
    diff = b.astype(float).to_numpy() - a.astype(float).to_numpy()
    diff = diff[np.isfinite(diff)]
    _, p, _ = st.wilcoxon_signed_rank(diff)
    return "Wilcoxon signed-rank", p, int(diff.size), float(diff.mean()) if diff.size else math.nan


def table2(u, r, alpha: float = 0.05, pairs: dict | None = None) -> list[dict]:
    """Table II: for each metric, A and B, the test, its p-value and which strategy is better.  With
    ``pairs`` (see :func:`pair_keys`) each row also has the paired test over the A/B twins, which then
    decides "better" (same wind for both strategies: the more sensitive comparison)."""
    rows = []
    for key, label, level, col, better, wind_only in TABLE2:
        data = u if level == "uav" else r
        if wind_only:
            data = data[data["wind"] > 0]
        a = data[data["strategy"] == "A"][col]
        b = data[data["strategy"] == "B"][col]
        row = {"key": key, "metric": label, "n_A": int(a.notna().sum()), "n_B": int(b.notna().sum())}
        if key == "success":
            ka, na, kb, nb = int(a.sum()), len(a), int(b.sum()), len(b)
            row.update(A=f"{ka}/{na}", B=f"{kb}/{nb}", test="Fisher exact",
                       p=st.fisher_exact(ka, na - ka, kb, nb - kb) if na and nb else math.nan,
                       est_A=ka / na if na else math.nan, est_B=kb / nb if nb else math.nan)
        else:
            a = a.astype(float)
            b = b.astype(float)
            _, p = st.mann_whitney_u(a, b)
            if level == "run":
                row.update(A=f"{a.sum():.6g}", B=f"{b.sum():.6g}")
                est_a, est_b = a.mean(), b.mean()
            else:
                row.update(A=f"{a.mean():.2f} %", B=f"{b.mean():.2f} %")
                est_a, est_b = a.mean(), b.mean()
            if col == "distance_m":
                row.update(A=f"{a.sum() / 1000:.1f} km", B=f"{b.sum() / 1000:.1f} km")
            row.update(test="Mann-Whitney U", p=p, est_A=float(est_a), est_B=float(est_b))
        ea, eb = row["est_A"], row["est_B"]
        if not (math.isfinite(ea) and math.isfinite(eb)) or ea == eb:
            lead = "tie"
        elif (eb > ea) == (better == "higher"):
            lead = "B"
        else:
            lead = "A"
        row["lead"] = lead
        p = row["p"]
        if pairs:
            test, pp, npairs, mean_diff = _paired(data, col, level, pairs, key == "success")
            row.update(paired_test=test, paired_p=pp, n_pairs=npairs, paired_mean_diff=mean_diff)
            p = pp
        row["better"] = lead if (lead != "tie" and math.isfinite(p) and p < alpha) else "none"
        row["sense"] = better
        rows.append(row)
    return rows


# ============================================================================================ paper comparison
def _fmt_p(p: float) -> str:
    if not math.isfinite(p):
        return "n/a"
    return f"{p:.2g}" if p >= 0.001 else f"{p:.1e}"


def _slope_sig(ci: st.CI):
    return None if not math.isfinite(ci.low) else (ci.low > 0 or ci.high < 0)


def _mwu(x, y):
    return st.mann_whitney_u(np.asarray(x, float), np.asarray(y, float))[1]


def _facts(u, r, fd) -> dict:
    """Data-driven sentences that explain a comparison, keyed by claim."""
    f: dict = {}
    removed = u["outcome"].isin([UAV_COLLISION, ZONE_COLLISION])
    if len(u):
        kept = u[~removed]["remaining_battery_pct"]
        rt = u[removed]["removed_time"].astype(float)
        rb = u[removed]["remaining_battery_pct"].astype(float)
        f["battery_total"] = (f"{removed.mean() * 100:.0f} % of our UAV missions end in a collision (median at "
                              f"t = {rt.median():.0f} s, {rb.mean():.1f} % battery left on average); over the other "
                              f"missions the mean remaining battery is {kept.mean():.1f} %."
                              if removed.any() and len(kept) else "")
        f["battery_area"] = f["battery_total"]
        f["battery_zones"] = f["battery_total"]
    if len(u) and "distance_m" in u.columns:
        parts = []
        for s in sorted(set(u["strategy"])):
            sub = u[u["strategy"] == s]
            rm = sub["outcome"].isin([UAV_COLLISION, ZONE_COLLISION])
            d = sub[~rm]["distance_m"].astype(float)
            parts.append(f"{s}: {rm.mean() * 100:.0f} % of missions removed by a collision, the others flew "
                         f"{d.mean() / 1000:.2f} km on average")
        f["distance_total"] = "Per UAV mission: " + "; ".join(parts) + "."
        f["distance_wind"] = f.get("distance_wind", "")
    one = u[(u["n_uavs"] == 1) & (u["outcome"] == "success")]
    if len(one):
        cells = one.groupby(["strategy", "area"]).size()
        f["success_1"] = (f"A single UAV can fly our whole 24-target tour: {len(one)} single-UAV missions succeeded "
                          f"with {one['remaining_battery_pct'].mean():.1f} % battery left on average "
                          f"({', '.join(f'{k[0]}/{k[1]}: {v}' for k, v in cells.items())}).")
    two = u[u["n_uavs"] == 2]
    if len(two):
        oc = two.groupby("strategy")["outcome"].value_counts().unstack(fill_value=0)
        f["success_2"] = "Outcomes with 2 UAVs: " + "; ".join(
            f"{s}: " + ", ".join(f"{k} {int(v)}" for k, v in oc.loc[s].items() if v) for s in oc.index) + "."
    for s in ("A", "B"):
        sub = u[(u["strategy"] == s) & (u["outcome"] == UAV_COLLISION)]
        if len(sub):
            t = sub["removed_time"].astype(float)
            f.setdefault("wall_ratio", "")
            f["wall_ratio"] += (f"Strategy {s}: {len(sub)} UAVs removed by UAV-UAV collisions, median at "
                                f"t = {t.median():.0f} s, in fleets of "
                                f"{', '.join(str(n) for n in sorted(set(sub['n_uavs'])))} UAVs. ")
    f["collisions"] = f.get("wall_ratio", "")
    cells = r.groupby(["strategy", "n_uavs", "area"])["distance_m"].nunique()
    many = r.groupby(["strategy", "n_uavs", "area"]).size()
    idem = int(((cells == 1) & (many > 1)).sum())
    if idem and len(set(r["wind"])) > 1:
        f["battery_wind"] = (f"In {idem} of {len(cells)} (strategy, fleet, area) cells every run flew exactly the "
                             "same distance whatever its wind probability and seed: the wind did not reach the UAVs. "
                             "Check that the macro step is shorter than the wind decision interval: UavWind ramps "
                             "each wind episode up from 0 at its start, and with a step equal to the interval every "
                             "communication point falls on an episode start.")
        f["distance_wind"] = f["battery_wind"]
    return f


def paper_comparison(u, r, fd: dict, t2: list[dict]) -> list[dict]:
    """One row per published claim: the paper's value, ours, whether they agree (direction; ``sig`` says
    whether our difference or trend is statistically significant), the likely reasons and facts."""
    rows = []
    facts = _facts(u, r, fd)

    def add(key, ours, agree, why=(), note="", sig=None):
        paper, quote = PAPER[key]
        agree = None if agree is None else bool(agree)
        sig = None if sig is None else bool(sig)
        rows.append({"key": key, "paper": paper, "quote": quote, "ours": ours, "agree": agree, "sig": sig,
                     "why": list(why), "note": note, "fact": facts.get(key, "")})

    n_runs = r["run_id"].nunique()
    add("runs", f"{n_runs} completed runs", n_runs == 336,
        () if n_runs == 336 else ("campaign",), "" if n_runs == 336 else "this campaign is not the full paper grid")
    f5 = fd["fig5"]
    fleets = fd["fleets"]
    maxes = ", ".join(str(f5.get(("A", n), (0, 0))[1]) for n in fleets)
    add("max_success", maxes, maxes == "42, 84, 126, 168", () if maxes == "42, 84, 126, 168" else ("campaign",))

    def succ(s, n):
        k, m, _ = f5.get((s, n), (0, 0, None))
        return k, m
    if 1 in fleets:
        (ka, ma), (kb, mb) = succ("A", 1), succ("B", 1)
        add("success_1", f"{ka}/{ma} (A), {kb}/{mb} (B)", ka == 0 and kb == 0, ("geometry", "energy", "success_def"))
    if 2 in fleets:
        (ka, ma), (kb, mb) = succ("A", 2), succ("B", 2)
        add("success_2", f"{ka}/{ma} (A), {kb}/{mb} (B)", ka == 0 and kb > 0, ("geometry", "energy", "success_def"))
    srow = next(x for x in t2 if x["key"] == "success")
    add("success_dir", f"{srow['A']} (A) vs {srow['B']} (B), Fisher p = {_fmt_p(srow['p'])}",
        None if srow["lead"] == "tie" else srow["lead"] == "B", ("geometry", "collisions_model", "stochastic"),
        sig=srow["p"] < 0.05 if math.isfinite(srow["p"]) else None)
    bm = {s: battery_ci(u[u["strategy"] == s]["remaining_battery_pct"]) for s in ("A", "B")}
    erow = next(x for x in t2 if x["key"] == "energy")
    add("battery_total", f"{bm['A'].fmt(2, ' %')} (A), {bm['B'].fmt(2, ' %')} (B); Mann-Whitney p = "
                         f"{_fmt_p(erow['p'])}",
        bm["B"].estimate > bm["A"].estimate, ("energy", "geometry", "collisions_model"),
        "ours: mean remaining battery of all UAV missions, 95 % t interval",
        sig=erow["p"] < 0.05 if math.isfinite(erow["p"]) else None)
    parts, agree, sig = [], True, True
    for a in fd["areas"]:
        ca, cb = fd["fig6"][("A", a)], fd["fig6"][("B", a)]
        p = _mwu(u[(u["strategy"] == "A") & (u["area"] == a)]["remaining_battery_pct"],
                 u[(u["strategy"] == "B") & (u["area"] == a)]["remaining_battery_pct"])
        parts.append(f"{a}: A {ca.fmt(1)} vs B {cb.fmt(1)} (p = {_fmt_p(p)})")
        agree &= ca.estimate > cb.estimate
        sig &= math.isfinite(p) and p < 0.05
    add("battery_area", "; ".join(parts), agree, ("collisions_model", "geometry", "energy"), sig=sig)
    sl = st.ols_slope(u["wind"] * 100.0, u["remaining_battery_pct"])
    add("battery_wind", f"slope {sl.fmt(3)} %-points per %-point of wind probability",
        None if not math.isfinite(sl.estimate) else sl.estimate < 0, ("wind", "stochastic", "collisions_model"),
        "least-squares slope over all UAV missions, 95 % t interval", sig=_slope_sig(sl))
    zones = [a for a in fd["areas"] if _is_zone(a)]
    free = [a for a in fd["areas"] if not _is_zone(a)]
    if zones and free:
        xz, xf = u[u["area"].isin(zones)]["remaining_battery_pct"], u[u["area"].isin(free)]["remaining_battery_pct"]
        bz, bf, p = battery_ci(xz), battery_ci(xf), _mwu(xz, xf)
        add("battery_zones", f"zones {bz.fmt(1, ' %')} vs free {bf.fmt(1, ' %')} (p = {_fmt_p(p)})",
            bz.estimate > bf.estimate, ("collisions_model", "geometry"), sig=math.isfinite(p) and p < 0.05)
    drow = next(x for x in t2 if x["key"] == "distance")
    da, db = r[r["strategy"] == "A"]["distance_m"].sum() / 1000, r[r["strategy"] == "B"]["distance_m"].sum() / 1000
    add("distance_total", f"{da:.1f} km (A), {db:.1f} km (B); Mann-Whitney p = {_fmt_p(drow['p'])}", db < da,
        ("geometry", "collisions_model"), "sum of the distance flown by every UAV of every run",
        sig=drow["p"] < 0.05 if math.isfinite(drow["p"]) else None)
    if zones and free:
        xz, xf = r[r["area"].isin(zones)]["distance_m"] / 1000, r[r["area"].isin(free)]["distance_m"] / 1000
        dz, dfr, p = st.total_ci(xz, floor=0.0), st.total_ci(xf, floor=0.0), _mwu(xz, xf)
        add("distance_zones", f"zones {dz.fmt(1, ' km')} vs free {dfr.fmt(1, ' km')} (p = {_fmt_p(p)})",
            dz.estimate < dfr.estimate, ("collisions_model", "geometry"), sig=math.isfinite(p) and p < 0.05)
    sl = st.ols_slope(r["wind"] * 100.0, r["distance_m"] / 1000.0)
    add("distance_wind", f"slope {sl.fmt(3)} km per run per %-point of wind probability",
        None if not math.isfinite(sl.estimate) else sl.estimate > 0, ("wind", "stochastic", "collisions_model"),
        "least-squares slope over runs, 95 % t interval", sig=_slope_sig(sl))
    ca, cb = int(r[r["strategy"] == "A"]["collisions"].sum()), int(r[r["strategy"] == "B"]["collisions"].sum())
    crow = next(x for x in t2 if x["key"] == "collisions")
    add("collisions", f"{ca} (A), {cb} (B) UAVs removed; Mann-Whitney p = {_fmt_p(crow['p'])}", ca > cb,
        ("collisions_count", "collisions_model", "geometry"),
        sig=crow["p"] < 0.05 if math.isfinite(crow["p"]) else None)
    parts, agree = [], True
    for s in ("A", "B"):
        sub = r[r["strategy"] == s]
        nu, nz = int(sub["uav_collided"].sum()), int(sub["zone_collided"].sum())
        parts.append(f"{s}: {nz} zone vs {nu} UAV ({ratio_text(nz, nu)})")
        agree &= nu > 0 and 2.0 <= nz / nu <= 4.0
    add("wall_ratio", "; ".join(parts), agree, ("collisions_model", "geometry", "collisions_count"),
        "agreement = ratio between 2 and 4 in both strategies")
    parts, agree, sig = [], True, True
    for s in ("A", "B"):
        sub = u[u["strategy"] == s]
        sl = st.ols_slope(sub["n_uavs"], sub["remaining_battery_pct"])
        means = ", ".join(f"{n}: {fd['fig10'][(s, n)].estimate:.1f}" for n in fd["fleets"] if (s, n) in fd["fig10"])
        parts.append(f"{s}: slope {sl.fmt(2)} %/UAV (means {means})")
        agree = agree and math.isfinite(sl.estimate) and sl.estimate > 0
        sig = sig and bool(_slope_sig(sl))
    add("battery_fleet", "; ".join(parts), agree, ("energy", "geometry", "collisions_model"), sig=sig)
    nb = sum(1 for x in t2 if x["better"] == "B")
    na = sum(1 for x in t2 if x["better"] == "A")
    lb = sum(1 for x in t2 if x["lead"] == "B")
    add("table2", f"B significantly better on {nb}, A on {na}, no significant difference on {len(t2) - nb - na} "
                  f"(B ahead, significant or not, on {lb} of {len(t2)})", nb == len(t2),
        ("stochastic", "geometry", "collisions_model"))
    return rows


def _verdict(c: dict) -> str:
    if c["agree"] is None:
        return "n/a"
    text = "yes" if c["agree"] else "**no**"
    if c["sig"] is False:
        text += " (not significant)"
    return text


# ============================================================================================ figures
def _fig(w=7.5, h=4.5):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=(w, h), dpi=110)
    FigureCanvasAgg(fig)
    return fig, fig.add_subplot(1, 1, 1)


def _err(ci: st.CI, scale: float = 1.0):
    if not math.isfinite(ci.low):
        return [[0.0], [0.0]]
    return [[max(0.0, (ci.estimate - ci.low) * scale)], [max(0.0, (ci.high - ci.estimate) * scale)]]


def _wind_colors(winds):
    from matplotlib.colors import LinearSegmentedColormap
    cmap = LinearSegmentedColormap.from_list("paper_wind", ["#08306b", "#2171b5", "#41b6c4", "#41ab5d", "#00441b"])
    n = max(1, len(winds) - 1)
    return {w: cmap(i / n) for i, w in enumerate(winds)}


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path)
    return path


def _strategy_bars(ax, cis: dict, strategies, groups, width: float) -> None:
    """Side by side in each group, one bar per strategy with its interval (Figs. 6 and 10)."""
    for i, s in enumerate(strategies):
        for j, g in enumerate(groups):
            ci = cis[(s, g)]
            x = j + (i - (len(strategies) - 1) / 2) * width
            ax.bar(x, ci.estimate, width, color=COLORS.get(s, f"C{i}"), label=f"Strategy {s}" if j == 0 else None)
            ax.errorbar(x, ci.estimate, yerr=_err(ci), fmt="none", ecolor="black", capsize=3)


def draw_figures(fd: dict, out: Path) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    S, N, W, A = fd["strategies"], fd["fleets"], fd["winds"], fd["areas"]
    files = {}
    width = 0.8 / max(1, len(S))
    # -- Fig. 5
    fig, ax = _fig()
    for i, s in enumerate(S):
        xs = np.arange(len(N)) + (i - (len(S) - 1) / 2) * width
        for x, n in zip(xs, N):
            k, m, ci = fd["fig5"][(s, n)]
            ax.bar(x, k, width, color=COLORS.get(s, f"C{i}"), label=f"Strategy {s}" if n == N[0] else None)
            if m:
                ax.errorbar(x, k, yerr=[[max(0.0, k - ci.low * m)], [max(0.0, ci.high * m - k)]], fmt="none",
                            ecolor="black", capsize=3)
            ax.annotate(f"{k}/{m}", (x, k), xytext=(0, 3), textcoords="offset points", ha="center", fontsize=7)
    ax.set_xticks(np.arange(len(N)), [str(n) for n in N])
    ax.set_xlabel("UAVs in the fleet")
    ax.set_ylabel("successful UAV missions")
    ax.set_title("Fig. 5 - successes per fleet size (95 % Wilson interval)")
    ax.legend()
    files["fig5"] = _save(fig, out / "fig5_success_per_fleet_size.png")
    # -- Fig. 6
    fig, ax = _fig()
    _strategy_bars(ax, fd["fig6"], S, A, width)
    ax.set_xticks(np.arange(len(A)), A)
    ax.set_ylabel("mean remaining battery per UAV [%]")
    ax.set_title("Fig. 6 - remaining battery per area (95 % t interval)")
    ax.legend()
    files["fig6"] = _save(fig, out / "fig6_battery_per_area.png")
    # -- Fig. 7
    fig, ax = _fig(9, 4.8)
    colors = _wind_colors(W)
    groups = [(s, a) for s in S for a in A]
    bw = 0.85 / max(1, len(W))
    for g, (s, a) in enumerate(groups):
        for k, w in enumerate(W):
            ci = fd["fig7"][(s, a, w)]
            x = g + (k - (len(W) - 1) / 2) * bw
            ax.bar(x, ci.estimate if ci.n else 0, bw, color=colors[w], label=f"{w * 100:g} %" if g == 0 else None)
            if ci.n:
                ax.errorbar(x, ci.estimate, yerr=_err(ci), fmt="none", ecolor="black", capsize=1.5, lw=0.8)
    ax.set_xticks(np.arange(len(groups)), [f"{s} / {a}" for s, a in groups])
    ax.set_xlabel("strategy / area")
    ax.set_ylabel("mean remaining battery per UAV [%]")
    ax.set_title("Fig. 7 - remaining battery per wind probability (95 % t interval)")
    ax.legend(title="wind", fontsize=7, ncol=min(7, len(W)), loc="upper center", bbox_to_anchor=(0.5, -0.15))
    files["fig7"] = _save(fig, out / "fig7_battery_per_wind.png")
    # -- Fig. 8
    fig, ax = _fig(8, 4.8)
    for g, s in enumerate(S):
        for k, w in enumerate(W):
            ci = fd["fig8"][(s, w)]
            x = g + (k - (len(W) - 1) / 2) * bw
            ax.bar(x, ci.estimate, bw, color=colors[w], label=f"{w * 100:g} %" if g == 0 else None)
            ax.errorbar(x, ci.estimate, yerr=_err(ci), fmt="none", ecolor="black", capsize=1.5, lw=0.8)
    ax.set_xticks(np.arange(len(S)), [f"Strategy {s}" for s in S])
    ax.set_ylabel("total distance flown [km]")
    ax.set_title("Fig. 8 - total distance per wind probability (95 % interval: n x t interval of the run mean)",
                 fontsize=9)
    ax.legend(title="wind", fontsize=7, ncol=min(7, len(W)), loc="upper center", bbox_to_anchor=(0.5, -0.1))
    files["fig8"] = _save(fig, out / "fig8_distance_per_wind.png")
    # -- Fig. 9
    fig, ax = _fig()
    kinds = [("uav", "UAV"), ("zone", "restricted zone (wall)")]
    for i, s in enumerate(S):
        for j, (kind, label) in enumerate(kinds):
            ci = fd["fig9"][(s, kind)]
            x = j + (i - (len(S) - 1) / 2) * width
            ax.bar(x, ci.estimate, width, color=COLORS.get(s, f"C{i}"), label=f"Strategy {s}" if j == 0 else None)
            ax.errorbar(x, ci.estimate, yerr=_err(ci), fmt="none", ecolor="black", capsize=3)
            ax.annotate(f"{ci.estimate:.0f}", (x, ci.estimate), xytext=(0, 3), textcoords="offset points",
                        ha="center", fontsize=7)
    ax.set_xticks(np.arange(len(kinds)), [label for _, label in kinds])
    ax.set_xlabel("impact point")
    ax.set_ylabel("UAVs removed by a collision")
    ax.set_title("Fig. 9 - collisions per impact point (95 % interval: n x t interval of the run mean)", fontsize=9)
    ax.legend()
    files["fig9"] = _save(fig, out / "fig9_collisions_per_impact.png")
    # -- Fig. 10
    fig, ax = _fig()
    _strategy_bars(ax, fd["fig10"], S, N, width)
    ax.set_xticks(np.arange(len(N)), [str(n) for n in N])
    ax.set_xlabel("UAVs in the fleet")
    ax.set_ylabel("mean remaining battery per UAV [%]")
    ax.set_title("Fig. 10 - remaining battery per fleet size (95 % t interval)")
    ax.legend()
    files["fig10"] = _save(fig, out / "fig10_battery_per_fleet_size.png")
    return files


# ============================================================================================ markdown
def uav_report(manifest, df, out: Path) -> str | None:
    """The markdown of the report (figures written into ``out``); None when no UAV mission completed."""
    u, r = uav_frames(df)
    if u is None:
        return None
    fd = figure_data(u, r)
    files = draw_figures(fd, out)
    pairs = pair_keys(df, manifest)
    t2 = table2(u, r, pairs=pairs)
    cmp_rows = paper_comparison(u, r, fd, t2)
    L = [f"# Campaign report: {manifest['name']}", ""]
    L += [f"- {x}" for x in campaign_facts(manifest, df)]
    L += ["", "Statistics: success counts with 95 % Wilson score intervals and Fisher's exact test (two-sided); "
              "means with 95 % Student t intervals; totals over runs with n x the t interval of the per-run mean; "
              "A vs B on per-run and per-UAV metrics with the two-sided Mann-Whitney U test (exact for small "
              "samples without ties, normal approximation with tie and continuity corrections otherwise); trends "
              "as least-squares slopes with t intervals. Unit of analysis: the UAV mission for success and "
              "remaining battery (as the paper's 42/84/126/168), the run for distance, photos and collisions. "
              "Only completed runs are analysed. Intervals of quantities that cannot be negative are truncated at 0, "
              "of percentages also at 100, of UAVs removed at the number of UAVs that flew. "
              "Caveat: the UAV missions of one run are not independent (they share the wind and can collide with "
              "each other), so intervals and tests that treat missions as independent are indicative."
              + (" The campaign is paired on the strategy (same seed, i.e. same wind, for A and B): Table II also "
                 "compares each A run with its B twin, with Wilcoxon's signed-rank test (zeros dropped; exact "
                 "without ties, else the normal approximation with tie correction) and McNemar's exact test for "
                 "successes, and the paired test decides which strategy is better." if pairs else ""), ""]
    # comparison
    L += ["## Our numbers next to the paper's", ""]
    rows = [[c["key"], c["paper"], c["ours"], _verdict(c)] for c in cmp_rows]
    L += [md_table(["quantity", "paper", "ours", "agrees"], rows), ""]
    L += ["\"agrees\" compares directions (and the exact values where the paper gives them); \"not significant\" "
          "means our own difference or trend is not significant at α = 0.05 (its p-value or interval is in the row).",
          "", "Quotes (paper, section V):", ""]
    L += [f"- *{c['key']}*: {c['quote']}" + (f" — {c['note']}" if c["note"] else "") for c in cmp_rows]
    L += ["", "## Where and why we differ", ""]
    diff = [c for c in cmp_rows if c["agree"] is False or c["sig"] is False]
    if not diff:
        L += ["Every published claim is reproduced in direction.", ""]
    used: list[str] = []
    for c in diff:
        refs = []
        for w in c["why"]:
            if w in WHY and w not in used:
                used.append(w)
            if w in WHY:
                refs.append(f"[{used.index(w) + 1}]")
        lead = "This campaign does not cover the paper's full 336-run grid. " if "campaign" in c["why"] else ""
        verdict = "differs" if c["agree"] is False else "same direction, not significant here"
        L += [f"- **{c['key']}** ({verdict}) — paper: {c['paper']}; ours: {c['ours']}. {lead}{c['fact']} "
              f"Likely causes: {' '.join(refs) or '-'}"]
    if used:
        L += ["", "Causes:", ""]
        L += [f"{i + 1}. {WHY[w]}" for i, w in enumerate(used)]
    L += ["", _diagnostics(u, r), ""]
    # figures
    L += ["## Figures", ""]
    captions = {"fig5": "Fig. 5: successful UAV missions per fleet size and strategy",
                "fig6": "Fig. 6: mean remaining battery per area",
                "fig7": "Fig. 7: mean remaining battery per wind probability, by strategy and area",
                "fig8": "Fig. 8: total distance flown per wind probability",
                "fig9": "Fig. 9: collisions per impact point",
                "fig10": "Fig. 10: mean remaining battery per fleet size"}
    for k, p in files.items():
        L += [f"![{captions[k]}]({p.name})", "", f"*{captions[k]}.*", ""]
    # fig 5 table
    L += ["### Successes per fleet size (Fig. 5)", ""]
    rows = []
    for n in fd["fleets"]:
        row = [n]
        for s in fd["strategies"]:
            k, m, ci = fd["fig5"][(s, n)]
            row.append(f"{k}/{m} [{ci.low * m:.1f}, {ci.high * m:.1f}]" if m else "n/a")
        if {"A", "B"} <= set(fd["strategies"]):
            (ka, ma, _), (kb, mb, _) = fd["fig5"][("A", n)], fd["fig5"][("B", n)]
            row.append(_fmt_p(st.fisher_exact(ka, ma - ka, kb, mb - kb)) if ma and mb else "n/a")
        rows.append(row)
    L += [md_table(["UAVs", *[f"Strategy {s}" for s in fd["strategies"]], "Fisher p (A vs B)"], rows), ""]
    L += ["### Remaining battery (Figs. 6, 7, 10), mean % [95 % t interval]", ""]
    rows = [[s, a, fd["fig6"][(s, a)].fmt(1)] for s in fd["strategies"] for a in fd["areas"]]
    L += [md_table(["strategy", "area", "remaining battery"], rows), ""]
    rows = [[s, a] + [fd["fig7"][(s, a, w)].fmt(1) for w in fd["winds"]] for s in fd["strategies"]
            for a in fd["areas"]]
    L += [md_table(["strategy", "area", *[f"wind {w * 100:g} %" for w in fd["winds"]]], rows), ""]
    rows = [[s] + [fd["fig10"][(s, n)].fmt(1) for n in fd["fleets"]] for s in fd["strategies"]]
    L += [md_table(["strategy", *[f"{n} UAV" for n in fd["fleets"]]], rows), ""]
    L += ["### Total distance (Fig. 8), km [95 % interval]", ""]
    rows = [[s] + [fd["fig8"][(s, w)].fmt(1) for w in fd["winds"]] for s in fd["strategies"]]
    L += [md_table(["strategy", *[f"wind {w * 100:g} %" for w in fd["winds"]]], rows), ""]
    L += ["### Collisions per impact point (Fig. 9), UAVs removed [95 % interval]", ""]
    rows = [[s, fd["fig9"][(s, "uav")].fmt(0), fd["fig9"][(s, "zone")].fmt(0)] for s in fd["strategies"]]
    L += [md_table(["strategy", "UAV-UAV", "zone (wall)"], rows), ""]
    # table II
    L += ["## Table II - which strategy is better (α = 0.05)", ""]
    verdict = [x["better"] if x["better"] != "none" else f"no significant difference ({x['lead']} ahead)"
               for x in t2]
    if pairs:
        rows = [[x["metric"], x["A"], x["B"], x["test"], _fmt_p(x["p"]),
                 f"{x['paired_test']}, {x['n_pairs']} pairs", _fmt_p(x["paired_p"]), v, "B"]
                for x, v in zip(t2, verdict)]
        L += [md_table(["metric", "Strategy A", "Strategy B", "unpaired test", "p", "paired test", "paired p",
                         "better (ours, paired)", "paper"], rows), ""]
        L += ["The campaign is paired on the strategy (`paired: [strategy]`): each strategy-A run has a strategy-B "
              "twin with the same parameters, repetition and seed, i.e. the same wind. The paired tests compare the "
              "twins (per run, or per UAV of the same index) and decide \"better\".", ""]
    else:
        rows = [[x["metric"], x["A"], x["B"], x["test"], _fmt_p(x["p"]), v, "B"] for x, v in zip(t2, verdict)]
        L += [md_table(["metric", "Strategy A", "Strategy B", "test", "p", "better (ours)", "paper"], rows), ""]
    L += ["Direction: more successes, photos and remaining energy are better; less distance and fewer collisions "
          "are better (the paper's reading). \"with wind\" rows use the runs with a wind probability above 0.", ""]
    L += ["## Failed runs", "", failures_md(df)]
    return "\n".join(L)


def _diagnostics(u, r) -> str:
    """Facts from our runs that explain the comparison (outcome mix, when collisions happen)."""
    import pandas as pd
    lines = ["Mission outcomes of our UAV missions (per strategy and area):", ""]
    tab = u.groupby(["strategy", "area", "outcome"]).size().unstack(fill_value=0)
    header = ["strategy", "area", *[str(c) for c in tab.columns]]
    rows = [[s, a, *[int(v) for v in tab.loc[(s, a)].to_numpy()]] for s, a in tab.index]
    lines += [md_table(header, rows), ""]
    rem = pd.to_numeric(u["removed_time"], errors="coerce") if "removed_time" in u.columns else None
    if rem is not None and rem.notna().any():
        parts = []
        for s in sorted(set(u["strategy"])):
            x = rem[(u["strategy"] == s) & rem.notna()]
            if len(x):
                parts.append(f"{s}: {len(x)} removals, median at t = {x.median():.0f} s, "
                             f"{(x <= 120).mean() * 100:.0f} % within the first 2 min")
        lines += ["When collisions happen (simulation time of the removal): " + "; ".join(parts) + ".", ""]
    if "outcome" in u.columns:
        t = (u["outcome"] == "timeout").sum()
        if t:
            lines += [f"**{t} UAV mission(s) were still flying at the stop time** (outcome timeout): the campaign's "
                      "stop time is too short for them.", ""]
    return "\n".join(lines)
