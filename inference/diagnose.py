"""Explain a located mismatch and conclude on the omitted physics (issue 6, "explain" and "compare").

Generic: candidate physics reach this module as plain data (dicts; for soils, ``constitutive.physics_catalog``
writes them), each with a residual signature: items {covariate, role, weight, direction, curves, meaning}.

Signature score of a candidate (`rank_candidates`). For each signature item i with weight w_i:
  evidence_i = R^2_i  when the covariate was reported, its attribution (``inference.covariates.attribute``) is
                      significant (Holm-adjusted p <= alpha) and, when the item states a direction d_i = +-1, the
                      Spearman rank correlation rho_i between the covariate and the relative residual (pooled over the
                      points of the curves the item names) has the sign of d_i;
  evidence_i = 0      otherwise (status: "not reported", "not significant" or "opposite direction").
  score = sum_i w_i evidence_i / sum_i w_i (0 <= score <= 1; items whose covariate is not reported count as 0).
A candidate is *named* when the screening verdict is "structured mismatch", the base model does not already have the
physics, and at least one of its primary items supports it. Candidates are ranked by score.

Confirmation (`conclude`): a named candidate is confirmed when the log Bayes factor of its enriched model class over
the base class, ln B = ln Z_enriched - ln Z_base (TMCMC log-evidences), is at least ``threshold`` (default 3:
B >= 20, "strong" on the Kass & Raftery 1995 scale). The omitted physics is the best-ranked confirmed candidate, or
"none". A named candidate without an implemented enrichment is reported as "candidate named, enrichment not
available", never as confirmed.

Files of a finished case run (`write_input`, `diagnose_directory`, ``python -m inference.diagnose DIR``):
  DIR/diagnosis_input.json  settings, curves (test, curve, units), covariate names, candidates, model classes
                            {name, role "base" | "enriched", candidate, log_evidence, J_g, parameters, sigma_eps};
  DIR/diagnosis_input.npz   recorded x and y per curve, per class the MAP curves, posterior-sample curves and their
                            sigma_eps, and the base class's per-point covariates;
  DIR/diagnosis.json, DIR/diagnosis.md   the diagnosis (mismatch regions, ranked candidates with scores, log-evidence
                            of every class and Bayes factors, the omitted physics or "none", J_g, coverage and
                            structure statistics before and after).
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
from scipy import stats

from .covariates import per_curve
from .likelihood import Likelihood
from .mismatch import POSITION, relative_residuals, screen
from .observations import Curve, Observations, Test

__all__ = ["rank_candidates", "conclude", "write_input", "read_input", "diagnose_directory", "STRONG_LOG_BAYES"]

#: ln B at and above which the evidence for the enriched class is "strong" (B >= 20, Kass & Raftery 1995)
STRONG_LOG_BAYES = 3.0
ROLES = ("primary", "supporting")


# ================================================================ scoring
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


# ================================================================ run-directory files
def _key(i, what):
    return f"{what}__{i}"


def write_input(directory, likelihood, classes: list, covariates: dict, candidates: list, alpha=0.05,
                level=0.95, description="") -> Path:
    """Write DIR/diagnosis_input.{json,npz} for `diagnose_directory`.

    classes: [{name, role ("base" | "enriched"), candidate (enriched only), log_evidence, J_g, parameters
    {name: {map, mean, std, q2.5, q97.5}}, sigma_eps (MAP), map_simulated {(test, curve): values}, sample_simulated
    {(test, curve): (n_s, n)}, sample_sigma (n_s,)}]; covariates: per-point covariates of the base class in the form
    of ``screen``; candidates: plain-data catalog entries."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    keys = [(t.name, c) for t in likelihood.observations for c in t.curves]
    arrays = {}
    for i, (t, c) in enumerate(keys):
        curve = likelihood.observations[t].curves[c]
        arrays[_key(i, "x")], arrays[_key(i, "y")] = curve.x, curve.y
    meta_classes = []
    for j, cl in enumerate(classes):
        for i, k in enumerate(keys):
            arrays[_key(i, f"map{j}")] = np.asarray(cl["map_simulated"][k], dtype=float)
            arrays[_key(i, f"samples{j}")] = np.asarray(cl["sample_simulated"][k], dtype=float)
        arrays[f"sample_sigma__{j}"] = np.asarray(cl["sample_sigma"], dtype=float)
        meta_classes.append({k: v for k, v in cl.items()
                             if k not in ("map_simulated", "sample_simulated", "sample_sigma")})
    cov_names = list(covariates)
    for n, name in enumerate(cov_names):
        full = per_curve(name, covariates[name], {k: likelihood.observations[k[0]].curves[k[1]].y for k in keys})
        for i, k in enumerate(keys):
            if k in full:
                arrays[_key(i, f"cov{n}")] = full[k]
    meta = {"description": description, "alpha": float(alpha), "level": float(level), "floor": likelihood.floor,
            "curves": [{"test": t, "curve": c, "x_name": likelihood.observations[t].curves[c].x_name,
                        "y_name": likelihood.observations[t].curves[c].y_name,
                        "x_unit": likelihood.observations[t].curves[c].x_unit,
                        "y_unit": likelihood.observations[t].curves[c].y_unit} for t, c in keys],
            "tests": {t.name: {k: v for k, v in t.conditions.items() if isinstance(v, (str, int, float))}
                      for t in likelihood.observations},
            "covariates": cov_names, "candidates": candidates, "classes": meta_classes}
    (directory / "diagnosis_input.json").write_text(json.dumps(meta, indent=1) + "\n")
    np.savez_compressed(directory / "diagnosis_input.npz", **arrays)
    return directory


def read_input(directory):
    """(meta, Likelihood with the recorded curves, per-class dicts with arrays, covariates) from DIR."""
    directory = Path(directory)
    for name in ("diagnosis_input.json", "diagnosis_input.npz"):
        if not (directory / name).exists():
            raise FileNotFoundError(f"{directory / name} not found: the case writes it with --diagnose "
                                    "(inference.diagnose.write_input)")
    meta = json.loads((directory / "diagnosis_input.json").read_text())
    arrays = np.load(directory / "diagnosis_input.npz", allow_pickle=False)
    keys = [(d["test"], d["curve"]) for d in meta["curves"]]
    tests = {}
    for i, d in enumerate(meta["curves"]):
        tests.setdefault(d["test"], {})[d["curve"]] = Curve(arrays[_key(i, "x")], arrays[_key(i, "y")], d["x_name"],
                                                             d["y_name"], d["x_unit"], d["y_unit"])
    obs = Observations([Test(t, cs, meta["tests"].get(t, {})) for t, cs in tests.items()])
    like = Likelihood(obs, lambda params: {}, sigma=1.0, floor=meta["floor"])
    classes = []
    for j, cl in enumerate(meta["classes"]):
        classes.append({**cl, "map_simulated": {k: arrays[_key(i, f"map{j}")] for i, k in enumerate(keys)},
                        "sample_simulated": {k: arrays[_key(i, f"samples{j}")] for i, k in enumerate(keys)},
                        "sample_sigma": arrays[f"sample_sigma__{j}"]})
    covariates = {}
    for n, name in enumerate(meta["covariates"]):
        covariates[name] = {k: arrays[_key(i, f"cov{n}")] for i, k in enumerate(keys) if _key(i, f"cov{n}") in arrays}
    return meta, like, classes, covariates


def _structure(report) -> dict:
    """Residual-structure statistics of one screening, summarized for a before/after table."""
    curves = report.curves
    covs = [c.coverage for c in curves if c.coverage is not None]
    return {"verdict": report.verdict, "structured_curves": sum(c.structured for c in curves),
            "curves": len(curves), "regions": len(report.regions),
            "min_p_adjusted": float(min(min(c.p_adjusted.values()) for c in curves)),
            "mean_lag1": float(np.mean([c.lag1 for c in curves])),
            "mean_abs_mean_r": float(np.mean([abs(c.mean) for c in curves])),
            "coverage": float(np.mean(covs)) if covs else None,
            "points_outside": int(sum(c.n_outside or 0 for c in curves)),
            "points": int(sum(c.n_points for c in curves)), "screen_wall_s": report.wall_s}


def diagnose_directory(directory, threshold=STRONG_LOG_BAYES, n_shifts=1000) -> dict:
    """Screen every model class of a finished run, rank the candidates on the base class, conclude; writes
    DIR/diagnosis.json and DIR/diagnosis.md and returns the diagnosis dict."""
    t0 = time.perf_counter()
    directory = Path(directory)
    meta, like, classes, covariates = read_input(directory)
    alpha, level = meta["alpha"], meta["level"]
    screens, structure = {}, {}
    for cl in classes:
        base = cl["role"] == "base"
        rep = screen(like, cl["map_simulated"], cl["sigma_eps"], cl["sample_simulated"], cl["sample_sigma"],
                     covariates if base else None, alpha=alpha, level=level, n_shifts=n_shifts)
        screens[cl["name"]], structure[cl["name"]] = rep, _structure(rep)
    base = next(cl for cl in classes if cl["role"] == "base")
    residuals = relative_residuals(like, base["map_simulated"])
    ranked = rank_candidates(screens[base["name"]], residuals, covariates, meta["candidates"], alpha)
    verdict = conclude(ranked, classes, threshold)
    out = {"description": meta["description"], "alpha": alpha, "verdict": screens[base["name"]].verdict,
           "omitted_physics": verdict["omitted_physics"],
           "recommendation": _recommendation(verdict, ranked, screens[base["name"]]),
           "mismatch_regions": [{**r.to_dict(), "x_unit": like.observations[r.test].curves[r.curve].x_unit}
                                for r in screens[base["name"]].regions],
           "attribution": [a.to_dict() for a in screens[base["name"]].attribution],
           "candidates": [{**r, "decision": d["decision"]} for r, d in zip(ranked, verdict["candidates"])],
           "classes": [{k: cl.get(k) for k in ("name", "role", "candidate", "log_evidence", "J_g", "parameters",
                                                "sigma_eps", "wall_s")}
                       | {"log_bayes_vs_base": verdict["log_bayes"].get(cl["name"], 0.0 if cl["role"] == "base"
                                                                         else None),
                          "structure": structure[cl["name"]]} for cl in classes],
           "log_bayes": verdict["log_bayes"], "threshold_log_bayes": verdict["threshold"],
           "screens": {name: rep.to_dict() for name, rep in screens.items()}}
    out["wall_s"] = time.perf_counter() - t0
    (directory / "diagnosis.json").write_text(json.dumps(out, indent=1, default=_json_default) + "\n")
    (directory / "diagnosis.md").write_text(markdown(out, screens))
    return out


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON-serializable: {type(obj).__name__}")


def _recommendation(verdict, ranked, report) -> str:
    if report.verdict != "structured mismatch":
        return "no structured mismatch: no enrichment recommended"
    if verdict["omitted_physics"] != "none":
        return f"adopt the enriched class that adds {verdict['omitted_physics']}"
    named = [r["name"] for r in ranked if r["named"]]
    if not named:
        return "structured mismatch that no catalog signature explains: no enrichment recommended"
    return f"candidates named ({', '.join(named)}) but none confirmed by the Bayes factor: no enrichment adopted"


# ================================================================ report
def _fmt(v, spec=".3g"):
    return "-" if v is None else format(v, spec)


def _engineer_summary(d) -> list:
    """The conclusion in words, from the diagnosis dict."""
    if d["verdict"] != "structured mismatch":
        return ["The base model's residuals are consistent with the measurement noise (no test, curve or strain "
                "range misfits beyond the false-alarm level): nothing is missing that these records can reveal, and "
                "no enrichment is recommended."]
    lines = []
    by_test = {}
    for r in d["mismatch_regions"]:
        by_test.setdefault(r["test"], []).append(r)
    def region_words(r):
        where = "above" if r["sign"] == "+" else "below"
        unit = "" if r.get("x_unit", "-") == "-" else f" {r['x_unit']}"
        return (f"{r['curve']} at {r['x_start']:.3g}-{r['x_end']:.3g}{unit}: recorded {where} simulated by "
                f"{abs(100 * r['mean_relative']):.1f} %")

    parts = [f"{t} ({', '.join(region_words(r) for r in rs)})" for t, rs in by_test.items()]
    lines.append("Misfit located in " + ("; ".join(parts) if parts else "the curves' overall scatter or trend "
                                          "(no single contiguous region)") + ".")
    sig = [a for a in d["attribution"] if a["p_adjusted"] <= d["alpha"] and a["name"] != POSITION]
    if sig:
        lines.append("The structured residual is explained by " + ", ".join(
            f"{a['name']} ({a['kind']}-test, R^2 = {a['r2']:.2f}, p = {a['p_adjusted']:.2g})" for a in sig) + ".")
    top = d["candidates"][0]
    if top["named"]:
        said = [f"{i['meaning']} (rank correlation {_fmt(i['rank_correlation'], '+.2f')})"
                for i in top["items"] if i["status"] == "supports"]
        lines.append(f"This is the signature of {top['name']}: " + "; ".join(said) + ".")
    if d["omitted_physics"] != "none":
        cl = next(c for c in d["classes"] if c["role"] == "enriched" and c["candidate"] == d["omitted_physics"])
        lnb = d["log_bayes"][cl["name"]]
        bf = f"{math.exp(lnb):.3g}" if lnb < 700 else f"e^{lnb:.0f}"
        lines.append(f"The omitted physics is {d['omitted_physics']}: the evidence favours {cl['name']} over the "
                     f"base model by ln B = {lnb:.1f} (Bayes factor {bf}).")
    else:
        lines.append(f"Conclusion: {d['recommendation']}.")
    return lines


def markdown(d, screens) -> str:
    lines = ["# Missing-physics diagnosis", ""]
    if d["description"]:
        lines += [d["description"], ""]
    lines += ["## Conclusion", ""] + _engineer_summary(d) + ["", f"Omitted physics: **{d['omitted_physics']}**. "
                                                              f"Recommendation: {d['recommendation']}.", ""]
    lines += ["## Model classes (before / after)", "",
              "| class | role | ln Z | ln B vs base | J_g at MAP (per test) | sigma_eps | verdict | structured curves | "
              "regions | mean lag-1 | coverage (95 %) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in d["classes"]:
        s = c["structure"]
        jg = ", ".join(f"{t} {v:.3g}" for t, v in (c["J_g"] or {}).items() if isinstance(v, float))
        lines.append(f"| {c['name']} | {c['role']} | {_fmt(c['log_evidence'], '.2f')} | "
                     f"{_fmt(c['log_bayes_vs_base'], '+.2f')} | {jg} | {_fmt(c['sigma_eps'], '.4f')} | {s['verdict']} | "
                     f"{s['structured_curves']}/{s['curves']} | {s['regions']} | {s['mean_lag1']:+.2f} | "
                     f"{_fmt(None if s['coverage'] is None else 100 * s['coverage'], '.0f')} % |")
    for c in d["classes"]:
        if c["role"] == "enriched" and c.get("parameters"):
            lines += ["", f"Parameters of {c['name']} (posterior):", "", "| parameter | MAP | mean | std | 95 % interval |",
                      "|---|---|---|---|---|"]
            for n, p in c["parameters"].items():
                lines.append(f"| {n} | {p['map']:.4g} | {p['mean']:.4g} | {p['std']:.3g} | "
                             f"[{p.get('q2.5', float('nan')):.4g}, {p.get('q97.5', float('nan')):.4g}] |")
    lines += ["", "## Candidate physics ranked by signature score", "",
              "Score = sum of weight x R^2 over the signature items the screening supports (significant after Holm and "
              "in the expected direction), divided by the sum of the weights (inference.diagnose).", "",
              "| rank | candidate | score | named | decision | items (covariate: status) |", "|---|---|---|---|---|---|"]
    for k, c in enumerate(d["candidates"], 1):
        items = "; ".join(f"{i['covariate']}: {i['status']}" for i in c["items"])
        lines.append(f"| {k} | {c['name']} | {c['score']:.3f} | {'yes' if c['named'] else 'no'} | {c['decision']} | "
                     f"{items} |")
    for name, rep in screens.items():
        lines += ["", f"# Screening of {name}", "", rep.to_markdown()]
    return "\n".join(lines) + "\n"


def main(argv=None):
    import argparse

    ap = argparse.ArgumentParser(description="Missing-physics diagnosis of a finished case run directory "
                                             "(reads DIR/diagnosis_input.json and .npz, writes DIR/diagnosis.json and "
                                             "DIR/diagnosis.md)")
    ap.add_argument("directory", type=Path)
    ap.add_argument("--threshold", type=float, default=STRONG_LOG_BAYES,
                    help="ln Bayes factor needed to confirm an enrichment (default 3: B >= 20)")
    args = ap.parse_args(argv)
    d = diagnose_directory(args.directory, args.threshold)
    print(json.dumps({"directory": str(args.directory), "verdict": d["verdict"], "omitted_physics":
                      d["omitted_physics"], "log_bayes": d["log_bayes"], "wall_s": round(d["wall_s"], 3)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
