"""Explain a located mismatch with candidate physics, and conclude on the omitted physics by the Bayes factor.

Generic: candidate physics reach this module as plain data (dicts; for soils the cases' physics catalog writes them),
each with a residual signature: items {covariate, role, weight, direction, curves, meaning}.

Signature score of a candidate (`rank_candidates`). For each signature item i with weight w_i:
  evidence_i = R^2_i  when the covariate was reported, its attribution (`attribution.attribute`) is significant
                      (Holm-adjusted p <= alpha) and, when the item states a direction d_i = +-1, the Spearman rank
                      correlation rho_i between the covariate and the relative residual (pooled over the points of
                      the curves the item names) has the sign of d_i;
  evidence_i = 0      otherwise (status: "not reported", "not significant" or "opposite direction").
  score = sum_i w_i evidence_i / sum_i w_i (0 <= score <= 1; items whose covariate is not reported count as 0).
A candidate is *named* when the screening verdict is "structured mismatch", the base model does not already have the
physics, and at least one of its primary items supports it. Candidates are ranked by score.

Confirmation (`conclude`): a named candidate is confirmed when the log Bayes factor of its enriched model class over
the base class, ln B = ln Z_enriched - ln Z_base (TMCMC log-evidences), is at least ``threshold`` (default 3:
B >= 20, "strong" on the Kass & Raftery 1995 scale). The omitted physics is the best-ranked confirmed candidate, or
"none". A named candidate without an implemented enrichment is reported as "candidate named, enrichment not
available", never as confirmed.
"""
from __future__ import annotations

import numpy as np
from scipy import stats

from .attribution import per_curve

__all__ = ["STRONG_LOG_BAYES", "rank_candidates", "conclude"]

#: ln B at and above which the evidence for the enriched class is "strong" (B >= 20, Kass & Raftery 1995)
STRONG_LOG_BAYES = 3.0
ROLES = ("primary", "supporting")


def _check_candidate(c):
    for key in ("name", "signature"):
        if key not in c:
            raise ValueError(f"candidate {c.get('name', '?')!r}: missing field {key!r}")
    for item in c["signature"]:
        missing = {"covariate", "role", "weight", "direction"} - set(item)
        if missing:
            raise ValueError(f"candidate {c['name']!r}: signature item {item} lacks {sorted(missing)}")
        if item["role"] not in ROLES:
            raise ValueError(f"candidate {c['name']!r}: role {item['role']!r} must be one of {ROLES}")
        if item["direction"] not in (-1, 0, 1):
            raise ValueError(f"candidate {c['name']!r}: direction {item['direction']!r} must be -1, 0 or +1")
        if not item["weight"] > 0:
            raise ValueError(f"candidate {c['name']!r}: weight {item['weight']!r} must be > 0")


def _rank_correlation(residuals, covariate, curves):
    """Spearman rho between a numeric covariate and the residual, pooled over the points of ``curves`` (None: all);
    None when not computable (categorical, no points, constant)."""
    xs, rs = [], []
    for (t, c), r in residuals.items():
        if (curves is not None and c not in curves) or (t, c) not in covariate:
            continue
        v = np.asarray(covariate[t, c])
        if v.dtype.kind not in "biuf":
            return None
        ok = np.isfinite(r) & np.isfinite(v)
        xs.append(v[ok])
        rs.append(r[ok])
    if not xs:
        return None
    x, r = np.concatenate(xs), np.concatenate(rs)
    if x.size < 3 or np.ptp(x) == 0 or np.ptp(r) == 0:
        return None
    return float(stats.spearmanr(x, r)[0])


def rank_candidates(report, residuals: dict, covariates: dict, candidates: list, alpha=None) -> list:
    """Score and rank candidate physics against a screening (module docstring: the score and when a candidate is
    named). report: ScreenReport or its dict; residuals: {(test, curve): r} of the screened class; covariates: the
    per-point covariates given to ``screen``; candidates: plain-data catalog entries (each with ``signature``,
    optional ``in_base``, ``enrichment``, ``unavailable``). Returns dicts by decreasing score."""
    rep = report if isinstance(report, dict) else report.to_dict()
    alpha = rep["alpha"] if alpha is None else float(alpha)
    structured = rep["verdict"] == "structured mismatch"
    attribution = {a["name"]: a for a in rep["attribution"]}
    expanded = {name: per_curve(name, spec, residuals) for name, spec in covariates.items()}
    ranked = []
    for c in candidates:
        _check_candidate(c)
        items, num, den, primary = [], 0.0, 0.0, False
        for item in c["signature"]:
            name, want = item["covariate"], int(item["direction"])
            a = attribution.get(name)
            rho = _rank_correlation(residuals, expanded[name], item.get("curves")) if name in expanded else None
            if a is None:
                status = "not reported"
            elif a["p_adjusted"] > alpha:
                status = "not significant"
            elif want != 0 and (rho is None or np.sign(rho) != want):
                status = "opposite direction" if rho is not None else "direction not measurable"
            else:
                status = "supports"
            evidence = a["r2"] if status == "supports" else 0.0
            num += item["weight"] * evidence
            den += item["weight"]
            primary |= status == "supports" and item["role"] == "primary"
            items.append({**{k: item.get(k) for k in ("covariate", "role", "weight", "direction", "meaning")},
                          "r2": None if a is None else a["r2"], "p_adjusted": None if a is None else a["p_adjusted"],
                          "rank_correlation": rho, "status": status, "evidence": evidence})
        in_base = bool(c.get("in_base", False))
        named = structured and primary and not in_base
        ranked.append({"name": c["name"], "physics": c.get("physics", ""), "score": num / den if den else 0.0,
                       "named": named, "in_base": in_base, "enrichment": c.get("enrichment"),
                       "unavailable": c.get("unavailable", ""), "items": items})
    return sorted(ranked, key=lambda d: (-d["named"], -d["score"]))


def conclude(ranked: list, classes: list, threshold=STRONG_LOG_BAYES) -> dict:
    """The omitted physics from ranked candidates and model classes [{name, role, candidate, log_evidence, ...}].

    Returns {omitted_physics, log_bayes: {class: ln Z - ln Z_base}, candidates: [{name, decision}], threshold}."""
    base = [c for c in classes if c["role"] == "base"]
    if len(base) != 1:
        raise ValueError(f"classes need exactly one with role 'base', got {[c['name'] for c in base]}")
    lnz0 = base[0]["log_evidence"]
    enriched = {c["candidate"]: c for c in classes if c["role"] == "enriched"}
    log_bayes = {c["name"]: c["log_evidence"] - lnz0 for c in classes if c["role"] == "enriched"}
    omitted, decisions = "none", []
    for r in ranked:
        if not r["named"]:
            decision = "already in the base model" if r["in_base"] else "not named"
        elif r["enrichment"] is None:
            decision = f"candidate named, enrichment not available ({r['unavailable']})"
        elif r["name"] not in enriched:
            decision = "candidate named, enriched class not calibrated"
        else:
            lnb = log_bayes[enriched[r["name"]]["name"]]
            if lnb >= threshold and omitted == "none":
                omitted, decision = r["name"], f"confirmed: ln B = {lnb:.2f} >= {threshold:g}"
            elif lnb >= threshold:
                decision = f"also supported: ln B = {lnb:.2f} (ranked below {omitted})"
            else:
                decision = f"not confirmed: ln B = {lnb:.2f} < {threshold:g}"
        decisions.append({"name": r["name"], "decision": decision})
    return {"omitted_physics": omitted, "log_bayes": log_bayes, "threshold": float(threshold),
            "candidates": decisions}
