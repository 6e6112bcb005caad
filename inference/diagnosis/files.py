"""The files of a finished calibrate -> diagnose run, and the diagnosis of a run directory.

  DIR/diagnosis_input.json  settings (alpha, level, n_shifts, decision_rule: `records.DecisionRule.to_dict`),
                            curves (test, curve, units), covariate names, candidates, model classes
                            {name, role "base" | "enriched", candidate, log_evidence, J_g, parameters, sigma_eps};
  DIR/diagnosis_input.npz   recorded x and y per curve, per class the MAP curves, posterior-sample curves and their
                            sigma_eps, and the base class's per-point covariates;
  DIR/diagnosis.json, DIR/diagnosis.md   the diagnosis of `report.diagnose` (`records.Diagnosis.to_json`) and its
                            Markdown report.

``diagnose_directory(DIR)`` (also ``python -m inference.diagnosis DIR``) reads the input, diagnoses in memory with
the recorded settings and decision rule, and writes the diagnosis: the same as ``diagnose`` on the run's own
records, hence the loop's own conclusion. An input that records no rule is diagnosed under the threshold and margin
of the directory's diagnosis.json when there is one, else under the default rule.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..likelihood import Likelihood
from ..observations import Curve, Observations, Test
from .attribution import expand_covariates, split_spec
from .records import DecisionRule, Diagnosis, ModelClass
from .report import diagnose, markdown

__all__ = ["write_input", "read_input", "write_diagnosis", "recorded_rule", "diagnose_directory"]


def _key(i, what):
    return f"{what}__{i}"


def write_input(directory, likelihood, classes: list, covariates: dict, candidates: list, alpha=0.05,
                level=0.95, description="", rule=DecisionRule(), n_shifts=1000) -> Path:
    """Write DIR/diagnosis_input.{json,npz} for `diagnose_directory`.

    likelihood: the recorded curves' Likelihood; classes: model classes (``ModelClass`` or its dict: name, role
    "base" | "enriched", candidate (enriched only), log_evidence, J_g, parameters {name: {map, mean, std, q2.5,
    q97.5}}, sigma_eps (MAP), map_simulated {(test, curve): values}, sample_simulated {(test, curve): (n_s, n)},
    sample_sigma (n_s,), and any further plain-data fields); covariates: per-point covariates of the base class in
    the form of ``screen``; candidates: plain-data catalog entries; alpha, level, rule, n_shifts: the settings of
    the diagnosis (`report.diagnose`; a loop's are ``LoopResult.settings``)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    keys = [(t.name, c) for t in likelihood.observations for c in t.curves]
    arrays = {}
    for i, (t, c) in enumerate(keys):
        curve = likelihood.observations[t].curves[c]
        arrays[_key(i, "x")], arrays[_key(i, "y")] = curve.x, curve.y
    meta_classes = []
    for j, cl in enumerate(c.to_dict() if isinstance(c, ModelClass) else c for c in classes):
        for i, k in enumerate(keys):
            arrays[_key(i, f"map{j}")] = np.asarray(cl["map_simulated"][k], dtype=float)
            arrays[_key(i, f"samples{j}")] = np.asarray(cl["sample_simulated"][k], dtype=float)
        arrays[f"sample_sigma__{j}"] = np.asarray(cl["sample_sigma"], dtype=float)
        meta_classes.append({k: v for k, v in cl.items()
                             if k not in ("map_simulated", "sample_simulated", "sample_sigma")})
    expanded = expand_covariates(covariates, {k: likelihood.observations[k[0]].curves[k[1]].y for k in keys})
    cov_names = list(expanded)
    for n, name in enumerate(cov_names):
        for i, k in enumerate(keys):
            if k in expanded[name]:
                arrays[_key(i, f"cov{n}")] = expanded[name][k]
    meta = {"description": description, "alpha": float(alpha), "level": float(level), "n_shifts": int(n_shifts),
            "decision_rule": rule.to_dict(), "floor": likelihood.floor,
            "crossing_floor": likelihood.crossing_floor,
            "curves": [{"test": t, "curve": c, "x_name": likelihood.observations[t].curves[c].x_name,
                        "y_name": likelihood.observations[t].curves[c].y_name,
                        "x_unit": likelihood.observations[t].curves[c].x_unit,
                        "y_unit": likelihood.observations[t].curves[c].y_unit} for t, c in keys],
            "tests": {t.name: {k: v for k, v in t.conditions.items() if isinstance(v, (str, int, float))}
                      for t in likelihood.observations},
            "covariates": cov_names, "covariate_specs": {name: _declared(name, covariates[name]) for name in cov_names},
            "candidates": candidates, "classes": meta_classes}
    (directory / "diagnosis_input.json").write_text(json.dumps(meta, indent=1) + "\n")
    np.savez_compressed(directory / "diagnosis_input.npz", **arrays)
    return directory


def read_input(directory):
    """(meta, Likelihood with the recorded curves, [ModelClass] with their arrays, covariates) from DIR."""
    directory = Path(directory)
    for name in ("diagnosis_input.json", "diagnosis_input.npz"):
        if not (directory / name).exists():
            raise FileNotFoundError(f"{directory / name} not found: the case writes it with --diagnose "
                                    "(inference.diagnosis.write_input)")
    meta = json.loads((directory / "diagnosis_input.json").read_text())
    arrays = np.load(directory / "diagnosis_input.npz", allow_pickle=False)
    keys = [(d["test"], d["curve"]) for d in meta["curves"]]
    tests = {}
    for i, d in enumerate(meta["curves"]):
        tests.setdefault(d["test"], {})[d["curve"]] = Curve(arrays[_key(i, "x")], arrays[_key(i, "y")], d["x_name"],
                                                             d["y_name"], d["x_unit"], d["y_unit"])
    obs = Observations([Test(t, cs, meta["tests"].get(t, {})) for t, cs in tests.items()])
    like = Likelihood(obs, lambda params: {}, sigma=1.0, floor=meta["floor"],
                      crossing_floor=meta.get("crossing_floor", meta["floor"]))
    classes = []
    for j, cl in enumerate(meta["classes"]):
        classes.append(ModelClass.of({
            **cl, "map_simulated": {k: arrays[_key(i, f"map{j}")] for i, k in enumerate(keys)},
            "sample_simulated": {k: arrays[_key(i, f"samples{j}")] for i, k in enumerate(keys)},
            "sample_sigma": arrays[f"sample_sigma__{j}"]}))
    covariates = {}
    for n, name in enumerate(meta["covariates"]):
        values = {k: arrays[_key(i, f"cov{n}")] for i, k in enumerate(keys) if _key(i, f"cov{n}") in arrays}
        declared = meta.get("covariate_specs", {}).get(name)
        covariates[name] = {"values": values, **declared} if declared else values
    return meta, like, classes, covariates


def _declared(name, spec) -> dict:
    """The kind, scope and order of a declared covariate spec, as JSON (the abscissa is the recorded one on reading:
    a spec's own abscissa arrays are not stored)."""
    _, meta = split_spec(name, spec)
    return {k: v for k, v in meta.items() if k != "abscissa"}


def write_diagnosis(directory, diagnosis: Diagnosis) -> Path:
    """Write a diagnosis as DIR/diagnosis.json and its report DIR/diagnosis.md; returns DIR."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "diagnosis.json").write_text(diagnosis.to_json() + "\n")
    (directory / "diagnosis.md").write_text(markdown(diagnosis))
    return directory


def recorded_rule(directory, meta: dict) -> DecisionRule:
    """The decision rule of a run directory: its input's ``decision_rule``; without one, the threshold and margin of
    its diagnosis.json when there is one; else the default `records.DecisionRule`."""
    if "decision_rule" in meta:
        return DecisionRule.from_dict(meta["decision_rule"])
    written = Path(directory) / "diagnosis.json"
    if written.exists():
        d = json.loads(written.read_text())
        if "threshold_log_bayes" in d:
            return DecisionRule(d["threshold_log_bayes"], d.get("margin_log_bayes"))
    return DecisionRule()


def diagnose_directory(directory, rule: DecisionRule | None = None, n_shifts=None) -> Diagnosis:
    """Diagnose a finished run directory (`read_input`, `report.diagnose`) under its recorded settings and decision
    rule (`recorded_rule`; ``rule`` and ``n_shifts`` given here replace them); writes DIR/diagnosis.json and
    DIR/diagnosis.md and returns the `records.Diagnosis`."""
    meta, like, classes, covariates = read_input(directory)
    rule = recorded_rule(directory, meta) if rule is None else rule
    n_shifts = meta.get("n_shifts", 1000) if n_shifts is None else n_shifts
    out = diagnose(like, classes, covariates, meta["candidates"], meta["description"], meta["alpha"], meta["level"],
                   rule, n_shifts)
    write_diagnosis(directory, out)
    return out
