"""The study file's ``[enrichment.<candidate>]`` tables: the priors of the parameters an enrichment of the catalog
(:mod:`constitutive.physics_catalog`) adds, replacing the catalog's when the diagnosis loop calibrates that enriched
class, e.g.

    [enrichment.viscosity]
    C_alpha_e = [0.0005, 0.05]                  # a list keeps the catalog's prior form (log-uniform here)
    [enrichment.time_dependent_swelling]
    tau_s = { bounds = [3600.0, 1.0e6], prior = "uniform" }

A candidate is named as the catalog spells it (``"time-dependent swelling"``, quoted in TOML) or with ``_`` for its
blanks and hyphens (``time_dependent_swelling``). Units are the catalog's: C_alpha_e, kappa_s, chi0, xi, n_p, n_d
dimensionless, tau_s in s, permeability in m/s. Each table is checked as the base priors are: lower < upper, a
log-uniform lower bound > 0, each bound inside the parameter's physical range (> 0 where the model states none). An
unknown candidate or parameter, a candidate that adds no parameter, one outside the base model's family, one the
base already has, or one whose forward model the study lacks is refused with one line naming the file,
``enrichment.<candidate>.<parameter>`` and the value.
"""
from __future__ import annotations

from cases.study.checks import StudyError, did_you_mean
from constitutive import ParameterError, physics_catalog
from constitutive.registry import MODELS
from constitutive.swelling import SWELLING_RANGES

__all__ = ["read_enrichment_priors"]


def _key(name: str) -> str:
    """The TOML key of a candidate without quotes: blanks and hyphens as ``_``."""
    return name.replace(" ", "_").replace("-", "_")


def read_enrichment_priors(ck, table, model: str, switches: dict, has_sbp: bool) -> dict:
    """{candidate: {parameter: (lower, upper, "uniform" | "log-uniform")}} of the ``[enrichment]`` table of a study
    of ``model`` with ``switches`` (``has_sbp``: the study has a pressuremeter test, whose coupled FE takes the
    permeability of the partial-drainage enrichment). StudyError naming the field and the value otherwise."""
    ck.table(table, "enrichment")
    entries = {c["name"]: c for c in physics_catalog.signatures({**MODELS[model].catalog, **switches}, model)}
    names = {**{_key(n): n for n in entries}, **{n: n for n in entries}}
    out = {}
    for key, priors in table.items():
        where = f"enrichment.{key}"
        if key not in names:
            ck.fail(where, priors, f"not a candidate of the catalog; {did_you_mean(key, names)}candidates with "
                    f"parameters: {', '.join(_key(n) for n, c in entries.items() if _added(c) and not c['in_base'])}")
        name = names[key]
        entry = entries[name]
        if entry["enrichment"] is None:
            ck.fail(where, priors, f"no enrichment of {model} for {name!r}: {entry['unavailable']}")
        if entry["in_base"]:
            ck.fail(where, priors, f"the base model already has {name!r} ({', '.join(entry['present_when'])} = true): "
                    "no enriched class to give priors to")
        if not _added(entry):
            ck.fail(where, priors, f"the {name!r} enrichment adds no parameter (nothing to give a prior)")
        if entry["enrichment"]["forward_arguments"] and not has_sbp:
            ck.fail(where, priors, f"{physics_catalog.candidate(name).unavailable}; this study has no pressuremeter "
                    "test")
        if name in out:
            ck.fail(where, priors, f"{name!r} is given twice (as {name!r} and {_key(name)!r}): keep one")
        out[name] = _priors(ck, ck.table(priors, where), where, name, entry["enrichment"])
    return out


def _added(entry) -> bool:
    return entry["enrichment"] is not None and bool(entry["enrichment"]["parameters"])


def _priors(ck, priors: dict, where: str, name: str, enrichment: dict) -> dict:
    """{parameter: (lower, upper, kind)} of one candidate's table: the catalog's prior form unless the table gives
    another; each bound inside the parameter's physical range."""
    added = enrichment["parameters"]
    ranges = {**MODELS[enrichment["model_class"]].ranges, **SWELLING_RANGES}
    out = {}
    for k, v in priors.items():
        if k not in added:
            ck.fail(f"{where}.{k}", v, f"not a parameter of the {name!r} enrichment; {did_you_mean(k, added)}it "
                    f"adds {', '.join(added)}")
        default = "log-uniform" if k in enrichment["log_uniform"] else "uniform"
        lo, hi, kind = ck.bounds(v, f"{where}.{k}", default)
        if k not in ranges and not lo > 0:
            ck.fail(f"{where}.{k}", v, "the lower bound must be > 0")
        if k in ranges:
            for bound in (lo, hi):
                try:
                    ranges[k].check(k, bound, enrichment["model_class"])
                except ParameterError as exc:
                    raise StudyError(f"{ck.path}: {where}.{k} = {v!r}: {exc}") from None
        out[k] = (lo, hi, kind)
    return out
