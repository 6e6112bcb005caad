"""The study file: a TOML file naming the data files, the type and conditions of every test, the base model with
its fixed parameters and the priors of the free ones, the error parameter's bounds, the sampler and FE settings,
the synthetic-record generator, published or generating reference values (``[reference]``,
:mod:`cases.study.reading.reference`), the priors of the catalog's enrichments (``[enrichment]``,
:mod:`cases.study.reading.enrichment_priors`) and the route of the one runner (``[runner]``,
:mod:`cases.study.reading.runner_table`). Every field is checked before any solve (:mod:`cases.study.checks`).
The schema is documented in the README ("Your own recordings").
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

from cases.study.checks import Checker, StudyError, did_you_mean, fe_value, read_toml
from cases.study.reading.constraints import feasible_point, read_constraints
from cases.study.reading.enrichment_priors import read_enrichment_priors
from cases.study.reading.error_model import DEFAULT_SIGMA, ErrorModel, read_error_model
from cases.study.reading.flat_tests import test_spec
from cases.study.reading.presets import FE_FIELDS, PRESETS, Preset
from cases.study.reading.reference import read_references
from cases.study.reading.runner_table import read_runner
from constitutive import ParameterError
from constitutive.registry import MODELS, ModelSpec, build_model

__all__ = ["Settings", "Study", "load_study", "SAMPLER_DEFAULTS", "QUICK_DEFAULTS"]


@dataclass
class Settings:
    """Size of one class calibration: particles per stage, sweep cap per stage, posterior-predictive draws."""

    n_samples: int
    max_steps: int
    predictive_draws: int


SAMPLER_DEFAULTS = {"samples": 400, "max_steps": 8, "predictive_draws": 100}
QUICK_DEFAULTS = {"samples": 64, "max_steps": 4, "predictive_draws": 24}
TOP_LEVEL = ("name", "description", "model", "sigma_eps", "sampler", "fe", "tests", "synthetic", "reference", "runner",
             "enrichment")


@dataclass(frozen=True)
class Study:
    """A checked study file: its model class, fixed values, priors, tests, sampler and FE settings."""

    path: Path
    name: str
    description: str
    model: str
    switches: dict
    fixed: dict
    free: dict            # name -> (lower, upper)
    log_uniform: tuple    # names of the free parameters with a log-uniform prior
    sigma_bounds: tuple
    sigma_kind: str
    tests: tuple
    sampler: dict
    sampler_quick: dict
    fe: dict
    fe_quick: dict
    synthetic: dict
    error_model: ErrorModel | None = None   # [sigma_eps]: bounds and error groups (None: one sigma_eps, sigma_bounds)
    constraints: tuple = ()                 # inference.Constraint restricting the free parameters' prior
    references: dict = field(default_factory=dict)   # [reference]: {key: reference.Reference}
    runner: dict = field(default_factory=lambda: {"route": "study"})   # [runner]: the route and its settings
    #: [enrichment.<candidate>]: {candidate: {parameter: (lower, upper, kind)}} replacing the catalog's priors
    enrichment_priors: dict = field(default_factory=dict)

    @property
    def spec(self) -> ModelSpec:
        return MODELS[self.model]

    def settings(self, quick: bool, samples=None) -> Settings:
        s = self.sampler_quick if quick else self.sampler
        return Settings(samples or s["samples"], s["max_steps"], s["predictive_draws"])

    def preset(self, quick: bool) -> Preset:
        return replace(PRESETS["quick" if quick else "paper"], **(self.fe_quick if quick else self.fe))


def load_study(path, check_files=True) -> Study:
    """Read and validate a study file (every field, the data files exist, the model accepts the fixed values and
    the prior bounds). Raises StudyError naming the file, the table/field and the value."""
    path = Path(path)
    ck = Checker(path)
    doc = ck.table(read_toml(path), "", TOP_LEVEL, ("model", "tests"))
    name = ck.text(doc.get("name", path.stem), "name")
    description = doc.get("description", "")
    if not isinstance(description, str):
        ck.fail("description", description, "expected a string")

    # ---- model
    m = ck.table(doc["model"], "model", None, ("name",))
    model = ck.text(m["name"], "model.name", tuple(MODELS))
    spec = MODELS[model]
    ck.table(m, "model", ("name", "fixed", "free", "constraints", *spec.switches))
    switches = {k: ck.flag(m.get(k, v), f"model.{k}") for k, v in spec.switches.items()}
    fixed_in = ck.table(m.get("fixed", {}), "model.fixed")
    free_in = ck.table(m.get("free", {}), "model.free")
    if not free_in:
        raise StudyError(f"{path}: [model.free] is empty: name at least one free parameter with its prior bounds")
    known = ", ".join(spec.parameters)
    for table, values in (("model.fixed", fixed_in), ("model.free", free_in)):
        for k, v in values.items():
            if k == "sigma_eps":
                ck.fail(f"{table}.{k}", v, "the error parameter has its own table [sigma_eps] (bounds = [lo, hi])")
            if k not in spec.parameters:
                ck.fail(f"{table}.{k}", v, f"unknown parameter of {model}; {did_you_mean(k, spec.parameters)}its "
                        f"parameters are {known}")
    for k in set(fixed_in) & set(free_in):
        ck.fail(f"model.free.{k}", free_in[k], f"{k} is also in [model.fixed]: a parameter is either fixed or free")
    fixed = {k: ck.number(v, f"model.fixed.{k}") for k, v in fixed_in.items()}
    free, log_uniform = {}, []
    for k, v in free_in.items():
        lo, hi, kind = ck.bounds(v, f"model.free.{k}")
        free[k] = (lo, hi)
        if kind == "log-uniform":
            log_uniform.append(k)
    given = set(fixed) | set(free)
    for k in spec.required:
        if k not in given:
            raise StudyError(f"{path}: [model] {model} parameter {k} is missing: put it in [model.fixed] or "
                             "[model.free]")
    for group in spec.exactly_one:
        if len(given & set(group)) != 1:
            raise StudyError(f"{path}: [model] {model} needs exactly one of {' or '.join(group)} (fixed or free), got "
                             f"{sorted(given & set(group)) or 'none'}")
    for group in spec.at_most_one:
        if len(given & set(group)) > 1:
            raise StudyError(f"{path}: [model] {model} takes at most one of {' or '.join(group)}, got "
                             f"{sorted(given & set(group))}")
    for switch, names in spec.needs.items():
        for k in names:
            if switches[switch] and k not in given:
                raise StudyError(f"{path}: [model] {switch} = true needs {k} in [model.fixed] or [model.free]")
            if not switches[switch] and k in free:
                ck.fail(f"model.free.{k}", free_in[k], f"not used when {switch} = false (nothing to identify)")
    constraints = read_constraints(ck, m, spec, model, fixed, free, log_uniform)
    check_model_values(ck, model, switches, fixed, free, constraints)

    # ---- error parameter and sampler
    error_model = read_error_model(ck, doc.get("sigma_eps", DEFAULT_SIGMA))
    (lo, hi), sigma_kind = error_model.bounds, error_model.kind
    sampler_in = ck.table(doc.get("sampler", {}), "sampler", (*SAMPLER_DEFAULTS, "quick"))
    quick_in = ck.table(sampler_in.get("quick", {}), "sampler.quick", tuple(SAMPLER_DEFAULTS))
    sampler = {k: ck.integer(sampler_in.get(k, v), f"sampler.{k}", 5 if k == "samples" else 1)
               for k, v in SAMPLER_DEFAULTS.items()}
    quick = {k: ck.integer(quick_in.get(k, v), f"sampler.quick.{k}", 5 if k == "samples" else 1)
             for k, v in QUICK_DEFAULTS.items()}
    fe_in = ck.table(doc.get("fe", {}), "fe", (*FE_FIELDS, "quick"))
    fe_quick_in = ck.table(fe_in.get("quick", {}), "fe.quick", FE_FIELDS)
    fe, fe_quick = (fe_settings(ck, t, where) for t, where in ((fe_in, "fe"), (fe_quick_in, "fe.quick")))

    # ---- tests
    tests_in = doc["tests"]
    if not isinstance(tests_in, list) or not tests_in:
        ck.fail("tests", tests_in, "expected one or more [[tests]] tables")
    tests = tuple(test_spec(ck, t, i, spec, model, check_files) for i, t in enumerate(tests_in))
    names = [t.name for t in tests]
    for i, n in enumerate(names):
        if names.index(n) != i:
            ck.fail(f"tests[{n!r}].name", n, f"test names must be unique (entries {names.index(n) + 1} and {i + 1} "
                    "of [[tests]])")
    synthetic = ck.table(doc.get("synthetic", {}), "synthetic",
                         ("parameters", "switches", "noise", "seed", "points", "max_strain_pct"))
    references = read_references(ck, doc.get("reference", {}), spec.parameters)
    calibrated = [t.name for t in tests if t.role == "calibrate"]
    if not calibrated:
        ck.fail("tests", [t.name for t in tests], 'every test has role = "predict": at least one must be calibrated')
    runner = read_runner(ck, ck.table(doc.get("runner", {}), "runner"), names, tuple(references), calibrated)
    predicted = [i for i, t in enumerate(tests) if t.role == "predict"]
    if predicted and runner["route"] == "sbp":
        ck.fail(f"tests[{tests[predicted[0]].name!r}].role", "predict",
                'the pressuremeter route ([runner] route = "sbp") predicts no test; give role = "calibrate", leave '
                'the test out, or run the study on the general route (route = "study")')
    enrichment = read_enrichment_priors(ck, doc.get("enrichment", {}), model, switches,
                                        any("sbp" in (t.type, t.apparatus) for t in tests))
    return Study(path, name, description, model, switches, fixed, free, tuple(log_uniform), (lo, hi), sigma_kind,
                 tests, sampler, quick, fe, fe_quick, synthetic, error_model, constraints, references, runner,
                 enrichment)


def fe_settings(ck, table, where):
    out = {}
    for k, v in table.items():
        if k == "quick":
            continue
        out[k] = fe_value(ck, k, v, f"{where}.{k}")
    return out


def check_model_values(ck, model, switches, fixed, free, constraints=()):
    """Construct the model with the fixed values and each free parameter at its bounds (the others at mid-range, or
    at the nearest point satisfying the prior's ``constraints``; a bound no such point reaches is not checked):
    a value the model refuses is reported against its TOML field before any solve."""
    spec = MODELS[model]
    mid = {k: 0.5 * (lo + hi) for k, (lo, hi) in free.items()}
    if constraints:
        mid = feasible_point(free, constraints, mid)
    try:
        build_model(model, {**spec.defaults, **fixed, **mid}, switches)
    except (ParameterError, ValueError) as exc:
        raise StudyError(f"{ck.path}: [model.fixed] = {fixed}: {model} refuses these fixed values with the free "
                         f"parameters at mid-range {mid}: {exc}") from None
    for k, (lo, hi) in free.items():
        for label, v in (("lower", lo), ("upper", hi)):
            point = feasible_point(free, constraints, {**mid, k: v}, keep=k) if constraints else {**mid, k: v}
            if point is None:
                continue
            try:
                build_model(model, {**spec.defaults, **fixed, **point}, switches)
            except (ParameterError, ValueError) as exc:
                near = ", or nearest within the constraints" if constraints else ""
                ck.fail(f"model.free.{k}", [lo, hi], f"{model} refuses the {label} bound {v:g} (the other free "
                        f"parameters at mid-range{near}): {exc}")
