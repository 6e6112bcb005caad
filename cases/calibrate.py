"""A user's own recordings: calibrate a chosen base model on them and, with ``--diagnose``, run the missing-physics loop.

    python -m cases.calibrate study.toml [--diagnose] [--out DIR] [--quick] [--method de|o|both] [--samples N]
                                         [--seed S] [--runs R] [--resume] [--processes P]
    python -m cases.calibrate study.toml --generate [--noise X]   # (re)write the study's SYNTHETIC CSVs

The study file (TOML, read with the standard library's ``tomllib``) names the data files (paths relative to the TOML),
the type and conditions of every test, the base model with its fixed parameters and the priors of the free ones, the
bounds of the error parameter sigma_eps and the sampler settings. Everything is validated before any solve starts
(errors name the TOML file, the table and field, and the bad value; CSV errors name the file, the column and the
line), and nothing is written in ``--out`` when something is wrong. The schema and the CSV columns of each test type
are documented in notes/calibrate.md ("README section"); example studies with SYNTHETIC data are in cases/examples/.

Test types (units kPa, m, s; compression positive; strains in % in the files):
- ``triaxial``: drained or undrained, compression or extension, isotropically (p'0) or K0 (sigma'_v0, K0)
  consolidated, axial strain rate (``constitutive.labtests.drained_triaxial`` / ``undrained_triaxial``);
- ``oedometer_crs``: constant rate of strain from sigma'_v0 (``labtests.oedometer_crs``);
- ``oedometer_creep``: incremental oedometer, load stages held for a stage duration (``labtests.oedometer_loading``);
- ``sbp``: self-boring pressuremeter expansion (the coupled FE of ``cases.burswood_sbp.SBPForward``).

Base models: ``ModifiedCamClay``, ``ANICREEP`` (switches ``viscous``, ``anisotropy``, ``destructuration``) and
``SIMSAND`` (laboratory tests only; switches ``lode_dependence``, ``state_dependent_dilatancy``, the latter needing
n_p and n_d). ``--diagnose`` runs the loop of ``cases.concealed_viscosity`` (shared here: :func:`calibrate_class`,
:func:`run_loop`): calibrate the base class, locate the mismatch (``inference.screen``), explain it with per-point
covariates and ``constitutive.physics_catalog``, recalibrate the enriched class of the best-ranked named candidate
whose enrichment exists for the base model, compare log-evidences (``inference.diagnosis``).

Outputs in DIR (default results/calibrate/<study name>): summary.json (the DESIGN.md fields), report.md,
curves.png (recorded vs MAP with the 95 % posterior predictive band), marginals.png, stages.png, posterior.npz,
progress.log; with ``--diagnose`` also diagnosis_input.json/.npz, diagnosis.json/.md, diagnosis.png, loop.json and
the enriched class in DIR/enriched_<candidate>/.
"""
from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np

import inference
from constitutive import ANICREEP, ModifiedCamClay, SIMSAND, ParameterError, labtests, physics_catalog
from inference import DataError, ForwardModelError, diagnosis
from inference.observations import _converted, read_csv_table
from inference.priors import Bound

from . import burswood_sbp, study
from .study import generating_values, write_records
from .study.programme import TestSpec

__all__ = ["StudyError", "Settings", "LoopProblem", "calibrate_class", "run_loop", "class_name", "load_study",
           "load_observations", "StudyForward", "StudyProblem", "generate", "main"]

DEFAULT_OUT = Path("results") / "calibrate"


class StudyError(ValueError):
    """An invalid study file: the message names the TOML file, the table and field, and the value."""


# ====================================================================================================================
# The calibrate -> diagnose loop, shared with cases.concealed_viscosity
# ====================================================================================================================
@dataclass
class Settings:
    """Size of one class calibration: particles per stage, sweep cap per stage, posterior-predictive draws."""

    n_samples: int
    max_steps: int
    predictive_draws: int


def class_name(switches: dict, model: str = "ANICREEP") -> str:
    return f"{model}(" + ", ".join(f"{k}={v}" for k, v in sorted(switches.items())) + ")"


class LoopProblem:
    """What a case supplies to :func:`calibrate_class` and :func:`run_loop`: the base class, its forward model per
    class (switches), the MAP curves with the extra quantities the covariates need, the covariates, outputs."""

    case = "case"
    model = "ANICREEP"
    base_switches: dict = {}
    base_bounds: dict = {}
    base_log_uniform: tuple = ()
    sigma_bounds = {"sigma_eps": (0.002, 0.3)}
    sigma_kind = "uniform"
    #: where the base class is calibrated, relative to the loop's directory
    base_dir = "base"

    def forward(self, switches):
        """Batched forward model (``inference.Likelihood(batch=True)``) of the class with ``switches``."""
        raise NotImplementedError

    def map_curves(self, params: dict, switches: dict) -> dict:
        """{test: {curve: values at the records or (x, y)}} of one parameter set, with the extra curves the
        covariates use (``stress_ratio``, ``mean_stress``)."""
        raise NotImplementedError

    def covariates(self, like, map_curves) -> dict:
        raise NotImplementedError

    def catalog_switches(self, switches: dict) -> dict:
        """The switches the catalog's ``present_when`` is compared with."""
        return switches

    def also_enrich(self, diag: dict) -> list:
        """Further candidates (names, in this order) whose enriched class the loop calibrates after the best-ranked
        named one, from the first diagnosis ``diag``; none by default."""
        return []

    def executor(self):
        return inference.SerialExecutor()

    def summary_extra(self, switches: dict) -> dict:
        return {}

    def description(self, label: str, base_name: str) -> str:
        return f"Base class {base_name}; catalog: constitutive.physics_catalog ({label})."

    def prior(self, bounds: dict, log_uniform) -> inference.Prior:
        """Uniform free parameters, then sigma_eps, then the log-uniform ones (their order in theta)."""
        entries = [Bound(k, *map(float, v)) for k, v in bounds.items() if k not in log_uniform]
        entries += [Bound(k, *map(float, v), self.sigma_kind) for k, v in self.sigma_bounds.items()]
        entries += [Bound(k, *map(float, bounds[k]), "log-uniform") for k in log_uniform]
        return inference.Prior(entries)

    def outputs(self, args, seed, out, post, like, cls, map_curves):
        """Figures and reports of one calibrated class (after summary.json)."""

    def plot(self, path, like, classes, diag, label):
        """The loop's figure (diagnosis.png)."""


def calibrate_class(obs, name, switches, bounds, log_uniform, args, out, seed, settings, problem):
    """Calibrate one model class; returns (the class dict of inference.diagnosis.write_input, Posterior, Likelihood,
    MAP curves)."""
    t0 = time.perf_counter()
    like = inference.Likelihood(obs, problem.forward(switches), batch=True)
    prior = problem.prior(bounds, log_uniform)
    post = study.calibrate(like, prior, args, out, seed, settings.n_samples, executor=problem.executor(),
                           max_steps=settings.max_steps, progress=False)
    cls, map_raw, _ = finish_class(post, like, problem, name, switches, args, out, seed, settings.predictive_draws,
                                   time.perf_counter() - t0)
    return cls, post, like, map_raw


def finish_class(post, like, problem, name, switches, args, out, seed, draws, wall_s):
    """After one class's calibration: summary.json (with the class, its switches and ``wall_s``), the class dict
    (:func:`class_record`) and the problem's outputs. Returns (class dict, MAP raw curves, summary)."""
    summary = study.write_summary(out, problem.case, args, seed, post, like, extra={
        "model_class": name, "switches": switches, **problem.summary_extra(switches), "calibration_wall_s": wall_s})
    cls, map_raw = class_record(post, like, problem, name, switches, seed, draws, summary)
    problem.outputs(args, seed, out, post, like, cls, map_raw)
    return cls, map_raw, summary


def class_record(post, like, problem, name, switches, seed, draws, summary):
    """The class dict of inference.diagnosis.write_input (MAP curves, posterior-sample curves for the predictive band)
    and the MAP's raw curves."""
    params, sigma = like.split(post.map_theta)
    map_raw = problem.map_curves(params, switches)
    rng = np.random.default_rng(seed)
    rows = rng.choice(len(post.samples), size=min(draws, len(post.samples)), replace=False)
    sample_sims, sample_sigma = diagnosis.simulate_samples(like, post.samples[rows])
    q = post.quantiles()
    cls = {"name": name, "role": "base", "log_evidence": float(post.log_evidence), "J_g": summary["J_g_at_map"],
           "parameters": {n: {"map": post.map[n], "mean": post.mean[n], "std": post.std[n], "q2.5": q[n][0],
                              "q97.5": q[n][2]} for n in post.names},
           "sigma_eps": float(sigma), "wall_s": summary["calibration_wall_s"],
           "n_forward_solves": summary["n_forward_solves"], "map_simulated": like.simulated_at_observations(map_raw),
           "sample_simulated": sample_sims, "sample_sigma": sample_sigma}
    return cls, map_raw


def run_loop(obs, args, out: Path, seed: int, settings: Settings, label: str, problem: LoopProblem) -> dict:
    """Calibrate, locate, explain, enrich, recalibrate, compare; writes everything into ``out``."""
    t_loop = time.perf_counter()
    out = Path(out)
    base_switches = problem.base_switches
    candidates = physics_catalog.signatures(problem.catalog_switches(base_switches), problem.model)
    base, _, like, base_raw = calibrate_class(obs, class_name(base_switches, problem.model), base_switches,
                                              problem.base_bounds, problem.base_log_uniform, args,
                                              out / problem.base_dir, seed, settings, problem)
    cov = problem.covariates(like, base_raw)
    description = problem.description(label, base["name"])
    classes = [base]
    diagnosis.write_input(out, like, classes, cov, candidates, description=description)
    t0 = time.perf_counter()
    first = diagnosis.diagnose_directory(out)
    screen_s = time.perf_counter() - t0
    skipped, chosen = [], []
    for cand in first["candidates"]:
        if not cand["named"]:
            continue
        if cand["enrichment"] is None:  # none, or not for this model class (physics_catalog.signatures)
            skipped.append(cand["name"])
            continue
        chosen.append(cand["name"])
        break
    chosen += [name for name in problem.also_enrich(first) if name not in chosen]
    for name in chosen:
        switches, bounds, log_uniform = physics_catalog.enriched_settings(name, base_switches, problem.base_bounds,
                                                                          problem.model)
        enriched, _, _, _ = calibrate_class(obs, class_name(switches, problem.model), switches, bounds,
                                            tuple(problem.base_log_uniform) + tuple(log_uniform), args,
                                            out / f"enriched_{name.replace(' ', '_')}", seed, settings, problem)
        enriched.update(role="enriched", candidate=name)
        classes.append(enriched)
    if len(classes) > 1:
        diagnosis.write_input(out, like, classes, cov, candidates, description=description)
    final = diagnosis.diagnose_directory(out)
    problem.plot(out / "diagnosis.png", like, classes, final, label)
    timing = {"screen_and_rank_s": screen_s, "diagnose_final_s": final["wall_s"],
              "calibration_s": {c["name"]: c["wall_s"] for c in classes}, "loop_s": time.perf_counter() - t_loop}
    (out / "loop.json").write_text(json.dumps({"label": label, "seed": seed, "verdict": final["verdict"],
                                               "omitted_physics": final["omitted_physics"],
                                               "named": [c["name"] for c in final["candidates"] if c["named"]],
                                               "named_without_enrichment": skipped, "log_bayes": final["log_bayes"],
                                               "timing": timing, "settings": vars(settings)}, indent=1, default=float))
    return {**final, "timing": timing}


# ====================================================================================================================
# The study file
# ====================================================================================================================
@dataclass(frozen=True)
class ModelSpec:
    """A base model: its parameters, which are required, the switches it takes and its parameter defaults."""

    cls: type
    parameters: tuple
    required: tuple
    switches: dict = field(default_factory=dict)
    defaults: dict = field(default_factory=dict)
    exactly_one: tuple = ()
    at_most_one: tuple = ()
    #: the physics switches of the catalog (``present_when``) this model has
    catalog: dict = field(default_factory=dict)
    #: switch -> the parameters it needs (given when the switch is on, not free when it is off)
    needs: dict = field(default_factory=dict)
    #: the void ratio is a model parameter (else a condition of each test)
    e0_parameter: bool = False
    #: the laboratory drivers' substeps default to strain steps of at most this (None: the model's own triaxial
    #: integrator controls its substeps, one driver step per record)
    max_strain_step: float | None = 0.0025


MODELS = {
    "ModifiedCamClay": ModelSpec(ModifiedCamClay, ModifiedCamClay.parameter_names, ("M", "lambda_", "kappa"),
                                 exactly_one=(("G", "nu"),), at_most_one=(("pc0", "ocr"),),
                                 catalog={"viscous": False, "anisotropy": False}),
    "ANICREEP": ModelSpec(ANICREEP, ANICREEP.parameter_names, ("M", "lambda_", "kappa", "nu", "e0", "sigma_p0"),
                          switches={"viscous": True, "anisotropy": True, "destructuration": False},
                          defaults={"tau": 86400.0}, e0_parameter=True,
                          needs={"viscous": ("C_alpha_e",), "destructuration": ("chi0", "xi", "xi_d")}),
    "SIMSAND": ModelSpec(SIMSAND, SIMSAND.parameter_names,
                         tuple(k for k in SIMSAND.parameter_names if k not in ("n_p", "n_d")),
                         switches={"lode_dependence": True, "state_dependent_dilatancy": True},
                         catalog={"viscous": False, "anisotropy": False},
                         needs={"state_dependent_dilatancy": ("n_p", "n_d")}, max_strain_step=None),
}
#: models the pressuremeter FE runs in this entry point
SBP_MODELS = ("ANICREEP", "ModifiedCamClay")

TEST_TYPES = ("triaxial", "oedometer_crs", "oedometer_creep", "sbp")
#: fields of a [[tests]] entry per type: required, optional (name, file, type are common; consolidation-dependent
#: fields of the triaxial are checked separately)
TEST_FIELDS = {
    "triaxial": (("drainage", "direction", "consolidation", "strain_rate"),
                 ("p0", "sigma_v0", "K0", "e0", "substeps", "curves")),
    "oedometer_crs": (("sigma_v0", "K0", "strain_rate"), ("e0", "substeps", "curves")),
    "oedometer_creep": (("sigma_v0", "K0", "stage_stress", "stage_duration"), ("e0", "load_time", "n_times", "curves")),
    "sbp": (("sigma_v0", "K0", "u0", "permeability", "probe_radius", "strain_rate"), ("depth", "e0", "curves")),
}
#: number fields: > 0, >= 0 (u0, depth) or an integer >= minimum
POSITIVE = ("p0", "sigma_v0", "K0", "e0", "strain_rate", "permeability", "probe_radius", "stage_duration", "load_time")
NON_NEGATIVE = ("u0", "depth")
INTEGERS = {"substeps": 1, "n_times": 2}
CHOICES = {"drainage": ("drained", "undrained"), "direction": ("compression", "extension"),
           "consolidation": ("isotropic", "K0")}

#: CSV columns per test type: quantity -> (unit, role); role "x" (abscissa), "curve" (calibrated when present),
#: "required curve", "time" (optional record time)
COLUMNS = {
    "triaxial": {"axial_strain": ("%", "x"), "q": ("kPa", "required curve"), "p": ("kPa", "curve"),
                 "excess_pore_pressure": ("kPa", "curve"), "volumetric_strain": ("%", "curve"),
                 "void_ratio": ("-", "curve"), "time": ("s", "time")},
    "oedometer_crs": {"axial_strain": ("%", "x"), "sigma_v": ("kPa", "required curve"), "time": ("s", "time")},
    "oedometer_creep": {"time": ("s", "x"), "axial_strain": ("%", "required curve")},
    "sbp": {"cavity_strain": ("%", "x"), "cavity_pressure": ("kPa", "required curve"),
            "pore_pressure": ("kPa", "curve"), "time": ("s", "time")},
}
#: the abscissa quantity of each test type
X_COLUMN = {kind: next(q for q, (_, role) in cols.items() if role == "x") for kind, cols in COLUMNS.items()}
#: CSV quantity -> curve name (the catalog's stress-curve names: sigma'_v is "axial_stress")
CURVE_OF = {"sigma_v": "axial_stress"}
DRAINED_ONLY = ("volumetric_strain", "void_ratio")
UNDRAINED_ONLY = ("excess_pore_pressure",)
#: largest cavity strain of the FE expansion (cases.burswood_sbp.pressuremeter_problem), %
SBP_MAX_STRAIN_PCT = 10.0

SAMPLER_DEFAULTS = {"samples": 400, "max_steps": 8, "predictive_draws": 100}
QUICK_DEFAULTS = {"samples": 64, "max_steps": 4, "predictive_draws": 24}
FE_FIELDS = burswood_sbp.FE_FIELDS
TOP_LEVEL = ("name", "description", "model", "sigma_eps", "sampler", "fe", "tests", "synthetic")


@dataclass(frozen=True)
class Study:
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

    @property
    def spec(self) -> ModelSpec:
        return MODELS[self.model]

    def settings(self, quick: bool, samples=None) -> Settings:
        s = self.sampler_quick if quick else self.sampler
        return Settings(samples or s["samples"], s["max_steps"], s["predictive_draws"])

    def preset(self, quick: bool) -> burswood_sbp.Preset:
        return replace(burswood_sbp.PRESETS["quick" if quick else "paper"], **(self.fe_quick if quick else self.fe))


def read_toml(path) -> dict:
    """The parsed TOML file (tomllib, or the tomli package on Python 3.10)."""
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise StudyError(f"{path}: reading a study file needs Python >= 3.11 (tomllib) or the 'tomli' package "
                             "(pip install tomli)") from None
    path = Path(path)
    if not path.is_file():
        raise StudyError(f"{path}: study file not found")
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{path}: not valid TOML: {exc}") from None


class _Checker:
    """Error messages that name the TOML file, the table.field and the value."""

    def __init__(self, path):
        self.path = Path(path)

    def fail(self, where, value, why):
        raise StudyError(f"{self.path}: {where} = {value!r}: {why}")

    def table(self, value, where, allowed=None, required=()):
        if not isinstance(value, dict):
            self.fail(where, value, "expected a table")
        if allowed is not None:
            for k in value:
                if k not in allowed:
                    self.fail(f"{where}.{k}" if where else k, value[k],
                              f"unknown field; expected one of {', '.join(allowed)}")
        for k in required:
            if k not in value:
                raise StudyError(f"{self.path}: {where}.{k} is missing" if where else f"{self.path}: {k} is missing")
        return value

    def number(self, value, where, positive=False, non_negative=False):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(where, value, "expected a finite number")
        if positive and not value > 0:
            self.fail(where, value, "must be > 0")
        if non_negative and value < 0:
            self.fail(where, value, "must be >= 0")
        return float(value)

    def integer(self, value, where, minimum):
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            self.fail(where, value, f"expected an integer >= {minimum}")
        return int(value)

    def text(self, value, where, choices=None):
        if not isinstance(value, str) or not value.strip():
            self.fail(where, value, "expected a non-empty string")
        if choices is not None and value not in choices:
            self.fail(where, value, f"expected one of {', '.join(choices)}")
        return value

    def flag(self, value, where):
        if not isinstance(value, bool):
            self.fail(where, value, "expected true or false")
        return value

    def bounds(self, value, where, kind="uniform"):
        """[lower, upper] or {bounds = [lower, upper], prior = "uniform" | "log-uniform"} -> (lo, hi, kind)."""
        if isinstance(value, dict):
            self.table(value, where, ("bounds", "prior"), ("bounds",))
            kind = self.text(value.get("prior", kind), f"{where}.prior", ("uniform", "log-uniform"))
            value, where = value["bounds"], f"{where}.bounds"
        if not isinstance(value, list) or len(value) != 2:
            self.fail(where, value, "expected [lower, upper] or {bounds = [lower, upper], prior = \"log-uniform\"}")
        lo, hi = (self.number(v, where) for v in value)
        if not lo < hi:
            self.fail(where, value, "lower bound must be < upper bound")
        if kind == "log-uniform" and lo <= 0:
            self.fail(where, value, "a log-uniform prior needs a lower bound > 0")
        return lo, hi, kind


def load_study(path, check_files=True) -> Study:
    """Read and validate a study file (every field, the data files exist, the model accepts the fixed values and
    the prior bounds). Raises StudyError naming the file, the table/field and the value."""
    path = Path(path)
    ck = _Checker(path)
    doc = ck.table(read_toml(path), "", TOP_LEVEL, ("model", "tests"))
    name = ck.text(doc.get("name", path.stem), "name")
    description = doc.get("description", "")
    if not isinstance(description, str):
        ck.fail("description", description, "expected a string")

    # ---- model
    m = ck.table(doc["model"], "model", None, ("name",))
    model = ck.text(m["name"], "model.name", tuple(MODELS))
    spec = MODELS[model]
    ck.table(m, "model", ("name", "fixed", "free", *spec.switches))
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
                ck.fail(f"{table}.{k}", v, f"unknown parameter of {model}; its parameters are {known}")
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
    _check_model_values(ck, model, switches, fixed, free)

    # ---- error parameter and sampler
    s = ck.table(doc.get("sigma_eps", {"bounds": [0.002, 0.3]}), "sigma_eps", ("bounds", "prior"), ("bounds",))
    lo, hi, sigma_kind = ck.bounds(s, "sigma_eps")
    if lo < 0:
        ck.fail("sigma_eps.bounds", s["bounds"], "sigma_eps must be >= 0")
    sampler_in = ck.table(doc.get("sampler", {}), "sampler", (*SAMPLER_DEFAULTS, "quick"))
    quick_in = ck.table(sampler_in.get("quick", {}), "sampler.quick", tuple(SAMPLER_DEFAULTS))
    sampler = {k: ck.integer(sampler_in.get(k, v), f"sampler.{k}", 5 if k == "samples" else 1)
               for k, v in SAMPLER_DEFAULTS.items()}
    quick = {k: ck.integer(quick_in.get(k, v), f"sampler.quick.{k}", 5 if k == "samples" else 1)
             for k, v in QUICK_DEFAULTS.items()}
    fe_in = ck.table(doc.get("fe", {}), "fe", (*FE_FIELDS, "quick"))
    fe_quick_in = ck.table(fe_in.get("quick", {}), "fe.quick", FE_FIELDS)
    fe, fe_quick = (_fe_settings(ck, t, where) for t, where in ((fe_in, "fe"), (fe_quick_in, "fe.quick")))

    # ---- tests
    tests_in = doc["tests"]
    if not isinstance(tests_in, list) or not tests_in:
        ck.fail("tests", tests_in, "expected one or more [[tests]] tables")
    tests = tuple(_test_spec(ck, t, i, spec, model, check_files) for i, t in enumerate(tests_in))
    names = [t.name for t in tests]
    for i, n in enumerate(names):
        if names.index(n) != i:
            ck.fail(f"tests[{i}].name", n, "test names must be unique")
    synthetic = ck.table(doc.get("synthetic", {}), "synthetic",
                         ("parameters", "switches", "noise", "seed", "points", "max_strain_pct"))
    return Study(path, name, description, model, switches, fixed, free, tuple(log_uniform), (lo, hi), sigma_kind,
                 tests, sampler, quick, fe, fe_quick, synthetic)


def _fe_settings(ck, table, where):
    out = {}
    for k, v in table.items():
        if k == "quick":
            continue
        if k == "outer":
            out[k] = ck.text(v, f"{where}.{k}", ("fixed", "field"))
        elif k == "outer_radius_a0":
            out[k] = ck.number(v, f"{where}.{k}", positive=True)
        else:
            out[k] = ck.integer(v, f"{where}.{k}", 1)
    return out


def _check_model_values(ck, model, switches, fixed, free):
    """Construct the model with the fixed values and each free parameter at its bounds (the others at mid-range):
    a value the model refuses is reported against its TOML field before any solve."""
    spec = MODELS[model]
    mid = {k: 0.5 * (lo + hi) for k, (lo, hi) in free.items()}
    try:
        build_model(model, {**spec.defaults, **fixed, **mid}, switches)
    except (ParameterError, ValueError) as exc:
        raise StudyError(f"{ck.path}: [model.fixed] = {fixed}: {model} refuses these fixed values with the free "
                         f"parameters at mid-range {mid}: {exc}") from None
    for k, (lo, hi) in free.items():
        for label, v in (("lower", lo), ("upper", hi)):
            try:
                build_model(model, {**spec.defaults, **fixed, **mid, k: v}, switches)
            except (ParameterError, ValueError) as exc:
                ck.fail(f"model.free.{k}", [lo, hi], f"{model} refuses the {label} bound {v:g} (the other free "
                        f"parameters at mid-range): {exc}")


def _test_spec(ck, t, i, spec, model, check_files) -> TestSpec:
    where = f"tests[{i}]"
    ck.table(t, where, None, ("type", "file"))
    kind = ck.text(t["type"], f"{where}.type", TEST_TYPES)
    required, optional = TEST_FIELDS[kind]
    ck.table(t, where, ("name", "type", "file", *required, *optional), ("type", "file", *required))
    file = Path(ck.text(t["file"], f"{where}.file"))
    file = file if file.is_absolute() else ck.path.parent / file
    if check_files and not file.is_file():
        ck.fail(f"{where}.file", t["file"], f"data file not found ({file})")
    name = ck.text(t.get("name", file.stem), f"{where}.name")
    values = {}
    for k, v in t.items():
        w = f"{where}.{k}"
        if k in CHOICES:
            values[k] = ck.text(v, w, CHOICES[k])
        elif k in POSITIVE or k in NON_NEGATIVE:
            values[k] = ck.number(v, w, positive=k in POSITIVE, non_negative=k in NON_NEGATIVE)
        elif k in INTEGERS:
            values[k] = ck.integer(v, w, INTEGERS[k])
        elif k == "stage_stress":
            if not isinstance(v, list) or not v:
                ck.fail(w, v, "expected a list of vertical effective stresses (kPa), one per load stage")
            values[k] = tuple(ck.number(x, w, positive=True) for x in v)
        elif k == "curves":
            allowed = [CURVE_OF.get(q, q) for q, (_, role) in COLUMNS[kind].items() if "curve" in role]
            if not isinstance(v, list) or not v or any(c not in allowed for c in v):
                ck.fail(w, v, f"expected a non-empty list of curve names among {', '.join(allowed)}")
            values[k] = tuple(v)
    if kind == "triaxial":
        if values["consolidation"] == "isotropic":
            need, forbid = ("p0",), ("sigma_v0", "K0")
        else:
            need, forbid = ("sigma_v0", "K0"), ("p0",)
        for k in need:
            if k not in values:
                raise StudyError(f"{ck.path}: {where}.{k} is missing (consolidation = "
                                 f"{values['consolidation']!r} needs {' and '.join(need)})")
        for k in forbid:
            if k in values:
                ck.fail(f"{where}.{k}", t[k], f"not used with consolidation = {values['consolidation']!r} (give "
                        f"{' and '.join(need)})")
        if "curves" in values:
            wrong = DRAINED_ONLY if values["drainage"] == "undrained" else UNDRAINED_ONLY
            for c in values["curves"]:
                if c in wrong:
                    ck.fail(f"{where}.curves", t["curves"], f"curve {c!r} is not recorded in a "
                            f"{values['drainage']} test")
    if kind == "oedometer_creep" and values.get("load_time", 1.0) >= values["stage_duration"]:
        ck.fail(f"{where}.load_time", values.get("load_time", 1.0), f"must be < stage_duration "
                f"{values['stage_duration']:g} s")
    if kind == "sbp" and model not in SBP_MODELS:
        ck.fail(f"{where}.type", kind, f"the pressuremeter FE runs {' or '.join(SBP_MODELS)} here, not {model}")
    if spec.e0_parameter and "e0" in values:
        ck.fail(f"{where}.e0", t["e0"], f"e0 is a parameter of {model}: set it in [model.fixed] (or [model.free]), "
                "not per test")
    if not spec.e0_parameter and "e0" not in values:
        raise StudyError(f"{ck.path}: {where}.e0 is missing: {model} needs the void ratio at the start of each test")
    return TestSpec(name=name, type=kind, file=file, where=f"{ck.path}: {where} ({name})", **values)


# ====================================================================================================================
# Recorded curves
# ====================================================================================================================
def _data_lines(path) -> list:
    """File line numbers of the data rows of a CSV read by ``read_csv_table``."""
    lines, header = [], False
    with Path(path).open() as fh:
        for lineno, line in enumerate(fh, start=1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            if header:
                lines.append(lineno)
            header = True
    return lines


def _monotone(path, column, values, lines, decreasing=False, strict=True, what="increase"):
    steps = -np.diff(values) if decreasing else np.diff(values)
    bad = steps <= 0 if strict else steps < 0
    if np.any(bad):
        i = int(np.argmax(bad)) + 1
        raise DataError(f"{path}, line {lines[i]}, column {column!r}: value {values[i]:g} does not "
                        f"{what} (previous {values[i - 1]:g})")


def _check_table(spec: TestSpec, table: dict):
    """Columns known for the test type and in convertible units, the abscissa monotone and in range, positive
    stresses; returns the converted {quantity: values}. Errors name the file, the column and the line."""
    path, columns = spec.file, COLUMNS[spec.type]
    lines = _data_lines(path)
    for q, (unit, _) in table.items():
        if q not in columns:
            raise DataError(f"{path}: column {q!r} (unit {unit!r}) is not a column of a {spec.type} test; known: "
                            + ", ".join(f"{k}_{'pct' if u == '%' else u}" if u != "-" else k
                                        for k, (u, _) in columns.items()))
    for q, (unit, role) in columns.items():
        if role in ("x", "required curve") and q not in table:
            raise DataError(f"{path}: missing column {q!r} ({unit}) of a {spec.type} test; found {list(table)}")
    values = {q: _converted(path, q, u, v, columns[q][0]) for q, (u, v) in table.items()}
    x_name = X_COLUMN[spec.type]
    x = values[x_name]
    extension = spec.type == "triaxial" and spec.direction == "extension"
    if extension and x[0] > 0:
        raise DataError(f"{path}, line {lines[0]}, column {x_name!r}: value {x[0]:g}: an extension test has axial "
                        "strains <= 0 (compression positive)")
    if not extension and x[0] < 0:
        raise DataError(f"{path}, line {lines[0]}, column {x_name!r}: value {x[0]:g} must be >= 0"
                        + (" (compression positive; an extension test says direction = \"extension\")"
                           if spec.type == "triaxial" else ""))
    _monotone(path, x_name, x, lines, decreasing=extension, what="decrease" if extension else "increase")
    limit = SBP_MAX_STRAIN_PCT if spec.type == "sbp" else (None if x_name == "time" else 100.0)
    if limit is not None and np.max(np.abs(x)) > limit:
        i = int(np.argmax(np.abs(x) > limit))
        raise DataError(f"{path}, line {lines[i]}, column {x_name!r}: value {x[i]:g} % exceeds {limit:g} %"
                        + (" (the pressuremeter FE expands the cavity to 10 %)" if spec.type == "sbp" else ""))
    if "time" in values and x_name != "time":
        _monotone(path, "time", values["time"], lines, strict=False, what="increase or stay")
    for q in ("p", "sigma_v", "void_ratio", "cavity_pressure"):
        if q in values and np.any(values[q] <= 0):
            i = int(np.argmax(values[q] <= 0))
            raise DataError(f"{path}, line {lines[i]}, column {q!r}: value {values[q][i]:g} must be > 0")
    if spec.type == "triaxial":
        wrong = DRAINED_ONLY if spec.drainage == "undrained" else UNDRAINED_ONLY
        for q in wrong:
            if q in values:
                raise DataError(f"{path}: column {q!r} is not recorded in a {spec.drainage} test ({spec.where})")
    if spec.type == "oedometer_creep":
        creep_stage(spec, x, path, lines)
    return values


def creep_stage(spec: TestSpec, t, path=None, lines=None):
    """Stage index and time since the stage start of records at times ``t`` (s since the test start) of an
    incremental oedometer: stage k spans (k D, (k + 1) D], loaded during its first ``load_time`` s."""
    d = spec.stage_duration
    stage = np.maximum(np.ceil(t / d - 1e-12).astype(int) - 1, 0)
    local = t - stage * d
    bad = (stage >= len(spec.stage_stress)) | (local < spec.load_time * (1 - 1e-9))
    if path is not None and np.any(bad):
        i = int(np.argmax(bad))
        raise DataError(f"{path}, line {lines[i]}, column 'time': value {t[i]:g} s is not in a hold of the "
                        f"{len(spec.stage_stress)} stages of {d:g} s (each loaded during its first "
                        f"{spec.load_time:g} s)")
    return stage, local


def load_test(spec: TestSpec) -> tuple:
    """(inference.Test, record times in s or None) of one test's CSV, checked (:func:`_check_table`)."""
    meta, table = read_csv_table(spec.file)
    values = _check_table(spec, table)
    cols = COLUMNS[spec.type]
    x_name = X_COLUMN[spec.type]
    present = [q for q, (_, role) in cols.items() if "curve" in role and q in values]
    if spec.curves is not None:
        for c in spec.curves:
            if c not in [CURVE_OF.get(q, q) for q in present]:
                raise DataError(f"{spec.file}: curve {c!r} requested by {spec.where}.curves has no column in the file "
                                f"(found {list(table)})")
        present = [q for q in present if CURVE_OF.get(q, q) in spec.curves]
    conditions = {**meta, "test_type": spec.type, **{k: v for k, v in spec.conditions().items()
                                                     if isinstance(v, (str, int, float))}}
    if spec.type == "sbp":
        files = {spec.name: spec.file}
        obs = burswood_sbp.load_recordings(files, pore_pressure="pore_pressure" in present)
        test = obs[spec.name]
        test.conditions.update(conditions)
    else:
        curves = {CURVE_OF.get(q, q): inference.Curve(values[x_name], values[q], x_name, q, cols[x_name][0], cols[q][0])
                  for q in present}
        test = inference.Test(spec.name, curves, conditions, str(spec.file))
    times = values[x_name] if x_name == "time" else values.get("time")
    return test, times


def load_observations(study: Study) -> tuple:
    """(Observations, {test: record times or None}) of every test of the study."""
    loaded = [load_test(t) for t in study.tests]
    return inference.Observations([t for t, _ in loaded]), {t.name: times for t, (_, times) in zip(study.tests, loaded)}


# ====================================================================================================================
# Forward model
# ====================================================================================================================
def build_model(model: str, values: dict, switches: dict, vertical_axis=1):
    """The material-point model ``model`` with parameter values (scalars or (n,) arrays) and switches."""
    if model == "ANICREEP":  # an enrichment's switches may hold a parameter fixed (xi_d): the study's value wins
        return ANICREEP(**{**switches, **values}, vertical_axis=vertical_axis)
    return MODELS[model].cls(**switches, **values)


def _substeps(spec, strains, max_step):
    """Driver steps per recorded interval: the test's ``substeps``, else enough for strain steps <= max_step."""
    if spec.substeps is not None:
        return spec.substeps
    if max_step is None:
        return 1
    step = np.max(np.abs(np.diff(np.concatenate([[0.0], strains]))))
    return max(1, int(math.ceil(step / max_step - 1e-9)))


def _creep_weights(spec, times):
    """Indices and weights that interpolate an oedometer_loading record (n_stages * n_times log-spaced hold times)
    to the recorded times, linearly in the logarithm of the time since the stage start (exact at the driver's times)."""
    stage, local = creep_stage(spec, times)
    hold = np.log(np.geomspace(spec.load_time, spec.stage_duration, spec.n_times))
    pos = np.clip(np.searchsorted(hold, np.log(local)) - 1, 0, spec.n_times - 2)
    w = np.clip((np.log(local) - hold[pos]) / (hold[pos + 1] - hold[pos]), 0.0, 1.0)
    i0 = stage * spec.n_times + pos
    return i0, i0 + 1, w


def simulate_lab(spec: TestSpec, model, e0, x, max_step=None) -> dict:
    """Curves of one laboratory test for a batch (m,) at the recorded abscissae ``x`` (strain in % or time in s):
    {curve: (m, n)} with the calibrated curve names plus ``stress_ratio`` and ``mean_stress`` (kPa), for a model with
    a critical state line e_c(p') (SIMSAND) ``initial_state_parameter`` psi_0 = e_0 - e_c(p'_0) (constant along the
    curve), and ``failed``; ``max_step``: see :func:`_substeps`."""
    if spec.type == "triaxial":
        strains = np.asarray(x, dtype=float) / 100.0
        driver = labtests.drained_triaxial if spec.drainage == "drained" else labtests.undrained_triaxial
        c = driver(model, e0, spec.start_p, strains, k0=spec.k0, substeps=_substeps(spec, strains, max_step),
                   strain_rate=spec.strain_rate, on_failure="nan")
    elif spec.type == "oedometer_crs":
        strains = np.asarray(x, dtype=float) / 100.0
        c = labtests.oedometer_crs(model, e0, spec.sigma_v0, strains, spec.strain_rate, k0=spec.K0,
                                   substeps=_substeps(spec, strains, max_step), on_failure="nan")
    else:
        raw = labtests.oedometer_loading(model, e0, spec.sigma_v0, list(spec.stage_stress), spec.stage_duration,
                                         n_times=spec.n_times, load_time=spec.load_time, k0=spec.K0, on_failure="nan")
        i0, i1, w = _creep_weights(spec, np.asarray(x, dtype=float))
        c = {k: (v if k == "failed" else v[:, i0] * (1.0 - w) + v[:, i1] * w) for k, v in raw.items()}
    out = {"q": c["q"], "p": c["p"], "excess_pore_pressure": c["excess_pore_pressure"],
           "volumetric_strain": 100.0 * c["volumetric_strain"], "void_ratio": c["e"],
           "axial_stress": c["axial_stress"], "axial_strain": 100.0 * c["axial_strain"],
           "stress_ratio": c["q"] / c["p"], "mean_stress": c["p"]}
    if hasattr(model, "critical_void_ratio"):
        psi0 = e0 - model.critical_void_ratio(spec.start_p)  # scalar, or (m,) with per-particle parameters
        out["initial_state_parameter"] = np.broadcast_to(np.reshape(psi0, (-1, 1)), c["q"].shape)
    out["failed"] = c["failed"] | ~np.all(np.isfinite(c["q"]), axis=1)
    return out


class _SBP(burswood_sbp.SBPForward):
    """cases.burswood_sbp.SBPForward with the study's model (any of SBP_MODELS, switches, fixed values)."""

    def __init__(self, spec: TestSpec, preset, model, switches, fixed, e0, curves):
        site = {"sigma_v0": spec.sigma_v0, "K0": spec.K0, "u0": spec.u0, "permeability": spec.permeability,
                "a0": spec.probe_radius}
        super().__init__(preset, fixed={"e0": e0}, site=site, rates={spec.name: spec.strain_rate}, curves=curves)
        self.model, self.switches, self.values = model, dict(switches), dict(fixed)

    def material(self, params):
        return build_model(self.model, {**self.values, **params}, self.switches, vertical_axis=2)


#: the simulated quantities besides the calibrated curves that the covariates use (simulate_lab)
COVARIATE_CURVES = ("stress_ratio", "mean_stress", "initial_state_parameter")


class StudyForward:
    """Batched forward model of a study for one model class (``switches``): a list of parameter dicts (the free
    ones) -> a list of {test: {curve: values at the records, or (cavity strain %, values) for an SBP test}}, a
    ForwardModelError naming the failed tests in place of a failed particle. Laboratory tests run vectorized over
    the batch, one driver call per test; each SBP test is one FE solve per particle."""

    def __init__(self, study: Study, observations, switches: dict, preset=None):
        self.study = study
        self.model = study.model
        self.switches = dict(switches)
        self.fixed = {**study.spec.defaults, **study.fixed}
        self.x = {t.name: next(iter(t.curves.values())).x for t in observations}
        self.curves = {t.name: tuple(t.curves) for t in observations}
        self.sbp = {}
        for spec in study.tests:
            if spec.type == "sbp":
                e0 = self.fixed["e0"] if study.spec.e0_parameter else spec.e0
                self.sbp[spec.name] = _SBP(spec, preset or study.preset(False), self.model, self.switches,
                                           self.fixed, e0, self.curves[spec.name])

    def simulate(self, params: dict) -> tuple:
        """params {name: (m,) array} -> ({lab test: {curve: (m, n)}}, {lab test: failed (m,)})."""
        m = int(np.size(next(iter(params.values()))))
        values = {k: np.broadcast_to(np.asarray(v, dtype=float), (m,)).copy() for k, v in {**self.fixed,
                                                                                             **params}.items()}
        model = build_model(self.model, values, self.switches)
        curves, failed = {}, {}
        for spec in self.study.tests:
            if spec.type == "sbp":
                continue
            e0 = values["e0"] if self.study.spec.e0_parameter else spec.e0
            c = simulate_lab(spec, model, e0, self.x[spec.name], self.study.spec.max_strain_step)
            failed[spec.name] = c.pop("failed")
            curves[spec.name] = c
        return curves, failed

    def __call__(self, batch):
        names = list(batch[0])
        try:
            curves, failed = self.simulate({n: np.array([p[n] for p in batch], dtype=float) for n in names})
        except (ParameterError, ValueError) as exc:
            if len(batch) == 1:
                return [ForwardModelError(f"{class_name(self.switches, self.model)}: {exc}")]
            raise  # the likelihood retries particle by particle and records each one's reason
        out = []
        for i, params in enumerate(batch):
            bad = [t for t, f in failed.items() if f[i]]
            result = {t: {c: curves[t][c][i] for c in self.curves[t] + COVARIATE_CURVES if c in curves[t]}
                      for t in curves}
            for name, sbp in self.sbp.items():
                if bad:  # this particle has already failed: no FE solve for it
                    break
                try:
                    result.update(sbp(params))
                except Exception as exc:  # noqa: BLE001 - an FE failure is this particle's zero likelihood
                    bad.append(f"{name} ({type(exc).__name__}: {exc})")
            out.append(ForwardModelError(f"{class_name(self.switches, self.model)}: integration failed in {bad}")
                       if bad else result)
        return out


# ====================================================================================================================
# The study as a loop problem
# ====================================================================================================================
LABELS = {"q": "q (kPa)", "p": "p' (kPa)", "excess_pore_pressure": "excess pore pressure (kPa)",
          "volumetric_strain": "volumetric strain (%)", "void_ratio": "void ratio e",
          "axial_stress": "sigma'_v (kPa)", "axial_strain": "axial strain (%)",
          "cavity_pressure": "total cavity pressure (kPa)", "pore_pressure": "pore pressure at the wall (kPa)"}
X_LABELS = {"axial_strain": "axial strain (%)", "time": "time (s)", "cavity_strain": "cavity strain (%)"}
CASE = "calibrate"


class StudyProblem(LoopProblem):
    """A study file's base model as a :class:`LoopProblem`."""

    case = CASE

    def __init__(self, study: Study, observations, times: dict, quick: bool, processes=None, dispatch="dynamic"):
        self.study = study
        self.observations = observations
        self.times = times
        self.model = study.model
        self.base_switches = dict(study.switches)
        self.base_bounds = dict(study.free)
        self.base_log_uniform = tuple(study.log_uniform)
        self.sigma_bounds = {"sigma_eps": study.sigma_bounds}
        self.sigma_kind = study.sigma_kind
        self.base_dir = "."
        self.preset = study.preset(quick)
        self.processes, self.dispatch = processes, dispatch
        self.synthetic = any("synthetic" in t.conditions for t in observations)
        self.generating = generating_values(observations)

    def forward(self, switches):
        return StudyForward(self.study, self.observations, switches, self.preset)

    def map_curves(self, params, switches):
        return self.forward(switches)([params])[0]

    def catalog_switches(self, switches):
        return {**self.study.spec.catalog, **switches}

    def executor(self):
        return inference.default_executor(self.dispatch, self.processes)

    def summary_extra(self, switches):
        s = self.study
        return {"study": s.name, "study_file": str(s.path), "model": s.model, "fixed": s.fixed,
                "priors": {n: {"bounds": list(b), "prior": "log-uniform" if n in s.log_uniform else "uniform"}
                           for n, b in s.free.items()},
                "tests": {t.name: {"file": str(t.file), **t.conditions()} for t in s.tests},
                "fe": ({k: getattr(self.preset, k) for k in FE_FIELDS} if any(t.type == "sbp" for t in s.tests)
                       else None),
                "synthetic_recordings": self.synthetic, "generating": self.generating}

    def description(self, label, base_name):
        free = ", ".join(self.study.free)
        return ((f"**SYNTHETIC data** ({label}). " if self.synthetic else f"Recordings ({label}). ")
                + f"Study {self.study.name} ({self.study.path}); base class {base_name} with {free}, sigma_eps free; "
                "catalog: constitutive.physics_catalog.")

    def covariates(self, like, map_curves) -> dict:
        """Per-point covariates (names from physics_catalog.COVARIATES): strain rate (test condition), time, strain
        level, the MAP's stress ratio and p', loading phase, stress-path direction, consolidation and (SIMSAND) the
        initial state parameter at the MAP's critical state line (test conditions); a between-test covariate is kept
        only when it takes at least two values."""
        cov = {k: {} for k in ("strain rate", "time", "strain level", "stress ratio", "mean effective stress",
                               "loading phase", "stress path direction", "consolidation", "initial state parameter")}
        for spec in self.study.tests:
            test = like.observations[spec.name]
            for c, curve in test.curves.items():
                k = (spec.name, c)
                times = self.times.get(spec.name)
                if spec.type == "oedometer_creep":
                    cov["time"][k] = curve.x
                    cov["strain level"][k] = np.abs(np.asarray(map_curves[spec.name]["axial_strain"])) / 100.0
                else:
                    cov["strain rate"][k] = spec.strain_rate
                    cov["strain level"][k] = np.abs(curve.x) / 100.0
                    cov["time"][k] = times if times is not None else np.abs(curve.x) / 100.0 / spec.strain_rate
                if "stress_ratio" in map_curves[spec.name]:
                    cov["stress ratio"][k] = np.asarray(map_curves[spec.name]["stress_ratio"])
                    cov["mean effective stress"][k] = np.asarray(map_curves[spec.name]["mean_stress"])
                if "initial_state_parameter" in map_curves[spec.name]:
                    cov["initial state parameter"][k] = float(map_curves[spec.name]["initial_state_parameter"][0])
                cov["loading phase"][k] = "hold" if spec.type == "oedometer_creep" else "load"
                if spec.type == "triaxial":
                    cov["stress path direction"][k] = spec.direction
                    cov["consolidation"][k] = spec.consolidation
        between = ("strain rate", "loading phase", "stress path direction", "consolidation",
                   "initial state parameter")
        return {k: v for k, v in cov.items()
                if v and (k not in between or len({str(x) for x in v.values()}) > 1)}

    def outputs(self, args, seed, out, post, like, cls, map_curves):
        write_outputs(out, args, post, like, cls, self)

    def plot(self, path, like, classes, diag, label):
        plot_loop(path, like, classes, diag, label, self.synthetic)


# ====================================================================================================================
# Outputs
# ====================================================================================================================
def write_outputs(out, args, post, like, cls, problem: StudyProblem):
    """report.md, curves.png, marginals.png, stages.png of one calibrated class (summary.json is written)."""
    out = Path(out)
    tag = "SYNTHETIC recordings" if problem.synthetic else "recordings"
    bands = diagnosis.predictive_bands(like, cls["sample_simulated"], cls["sample_sigma"])
    title = f"{problem.study.name}: {cls['name']}, {study.method_name(args.method)} ({tag})"
    plot_curves(out / "curves.png", like, cls["map_simulated"], bands, title)
    truth = problem.generating
    marks = {"generating (synthetic)": truth} if truth else None
    study.plot_marginals(post, out / "marginals.png", marks=marks,
                         bounds={**problem.study.free, "sigma_eps": problem.study.sigma_bounds}, title=title)
    study.plot_stages(post, out / "stages.png")
    summary = json.loads((out / "summary.json").read_text())
    lines = [f"# {problem.study.name}: {study.method_name(args.method)} calibration of {cls['name']}", ""]
    if problem.synthetic:
        lines += ["**The recordings are SYNTHETIC** (their `# synthetic` header lines say how they were made); they "
                  "are not measurements.", ""]
    if problem.study.description:
        lines += [problem.study.description, ""]
    lines += [f"- study file: {problem.study.path}"]
    lines += [f"- {t.name}: {t.describe()}, curves {', '.join(like.observations[t.name].curves)} ({t.file})"
              for t in problem.study.tests]
    lines += [f"- fixed: {json.dumps(problem.study.fixed)}",
              f"- N_s = {summary['n_samples']}, stages {summary['n_stages']}, forward evaluations "
              f"{summary['n_forward_solves']}, failed {summary['n_failed_solves']}, wall {summary['wall_s']:.1f} s on "
              f"{summary['ranks']} process(es) ({summary['executor']})",
              f"- ln Z = {post.log_evidence:.3f}; J_g at MAP: " + ", ".join(
                  f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in summary["J_g_at_map"].items()),
              "", study.parameter_table(post, {"generating (synthetic)": truth} if truth else None), ""]
    if truth:
        names = [n for n in post.names if n in truth]
        lines.append("Generating values inside the 95 % posterior interval: " + ", ".join(
            f"{n} {'yes' if lo <= truth[n] <= hi else 'NO'}" for n in names for lo, hi in [post.credible_interval(n)]))
        lines.append("")
    lines += ["Predictive coverage of the records (95 % band): " + ", ".join(
        f"{t} {c} {100 * b.coverage:.0f} %" for (t, c), b in bands.items()), "",
        "Figures: curves.png (records, MAP, 95 % posterior predictive band), marginals.png, stages.png."]
    (out / "report.md").write_text("\n".join(lines) + "\n")


def _panels(like):
    return [(t.name, c) for t in like.observations for c in t.curves]


def plot_curves(path, like, map_simulated, bands, title):
    """One row per test, one panel per curve: records, MAP and the 95 % posterior predictive band."""
    plt = study.pyplot()
    tests = list(like.observations)
    ncol = max(len(t.curves) for t in tests)
    fig, axes = plt.subplots(len(tests), ncol, figsize=(4.8 * ncol, 3.2 * len(tests)), squeeze=False)
    for row, t in zip(axes, tests):
        for ax, (c, curve) in zip(row, t.curves.items()):
            band = bands[t.name, c]
            ax.fill_between(curve.x, band.lower, band.upper, color="C0", alpha=0.25, lw=0,
                            label=f"95 % predictive ({100 * band.coverage:.0f} % inside)")
            ax.plot(curve.x, map_simulated[t.name, c], "C0-", lw=1.5, label="MAP")
            ax.plot(curve.x, curve.y, "o", ms=3, mfc="none", color="C3", label="recorded")
            ax.set_xlabel(X_LABELS.get(curve.x_name, curve.x_name))
            ax.set_ylabel(LABELS.get(c, c))
            ax.set_title(t.name, fontsize=9)
            ax.legend(fontsize=7)
        for ax in row[len(t.curves):]:
            ax.axis("off")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.45 / fig.get_figheight()))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_loop(path, like, classes, diag, label, synthetic):
    """Per recorded curve: data with the base (dashed) and enriched (solid) MAP, and below it the base class's
    relative residual with the mismatch regions shaded."""
    plt = study.pyplot()
    panels = _panels(like)
    ncol = min(4, len(panels))
    nrow = -(-len(panels) // ncol)
    fig, axes = plt.subplots(2 * nrow, ncol, figsize=(4.2 * ncol, 5.6 * nrow), squeeze=False)
    for j in range(len(panels), nrow * ncol):
        axes[2 * (j // ncol), j % ncol].axis("off")
        axes[2 * (j // ncol) + 1, j % ncol].axis("off")
    base, enriched = classes[0], (classes[1] if len(classes) > 1 else None)
    for j, (t, c) in enumerate(panels):
        row, col = 2 * (j // ncol), j % ncol
        curve, top, bottom = like.observations[t].curves[c], axes[row, col], axes[row + 1, col]
        top.plot(curve.x, curve.y, "o", ms=3, mfc="none", color="C3", label="recorded")
        top.plot(curve.x, base["map_simulated"][t, c], "k--", lw=1, label="base MAP")
        if enriched is not None:
            top.plot(curve.x, enriched["map_simulated"][t, c], "C0-", lw=1.3, label="enriched MAP")
        top.set_title(f"{t}: {c}", fontsize=9)
        top.set_ylabel(LABELS.get(c, c))
        top.legend(fontsize=7)
        bottom.plot(curve.x, 100 * (curve.y / base["map_simulated"][t, c] - 1.0), "o-", ms=3, lw=0.6, color="C3")
        for reg in diag["mismatch_regions"]:
            if reg["test"] == t and reg["curve"] == c:
                bottom.axvspan(reg["x_start"], reg["x_end"], color="C3", alpha=0.15)
        bottom.axhline(0, color="k", lw=0.6)
        bottom.set_xlabel(X_LABELS.get(curve.x_name, curve.x_name))
        bottom.set_ylabel("base residual U_obs/U_sim - 1 (%)")
    tag = "SYNTHETIC data" if synthetic else "recordings"
    fig.suptitle(f"{tag} ({label}): {diag['verdict']}; omitted physics: {diag['omitted_physics']}", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.45 / fig.get_figheight()))
    fig.savefig(path, dpi=100)
    plt.close(fig)


# ====================================================================================================================
# Synthetic recordings
# ====================================================================================================================
SYNTHETIC_DEFAULTS = {"noise": 0.02, "seed": 1, "points": 25}
#: default largest strain of a generated record (%), per test type
MAX_STRAIN_PCT = {"triaxial": 15.0, "oedometer_crs": 20.0, "sbp": SBP_MAX_STRAIN_PCT}
#: CSV quantities generated for a test without a ``curves`` field, per (type, drainage)
GENERATED = {("triaxial", "drained"): ("q", "void_ratio"), ("triaxial", "undrained"): ("q", "excess_pore_pressure"),
             ("oedometer_crs", None): ("sigma_v",), ("oedometer_creep", None): ("axial_strain",),
             ("sbp", None): ("cavity_pressure", "pore_pressure")}
QUANTITY_OF = {c: q for q, c in CURVE_OF.items()}


def generated_quantities(spec: TestSpec) -> tuple:
    """The CSV quantities the generator writes for a test: its ``curves`` field, else :data:`GENERATED`."""
    if spec.curves is not None:
        return tuple(QUANTITY_OF.get(c, c) for c in spec.curves)
    return GENERATED[spec.type, spec.drainage]


def _column(quantity, spec_type):
    unit = COLUMNS[spec_type][quantity][0]
    return quantity if unit == "-" else f"{quantity}_{'pct' if unit == '%' else unit}"


def synthetic_settings(study: Study, noise=None, seed=None) -> dict:
    """The study's [synthetic] table, checked: generating parameters (every free one, plus those the generating
    switches need), switches, noise, seed, points, max_strain_pct."""
    ck = _Checker(study.path)
    s = study.synthetic
    params = ck.table(s.get("parameters", {}), "synthetic.parameters")
    switches = {**study.switches, **ck.table(s.get("switches", {}), "synthetic.switches", tuple(study.switches))}
    for k, v in switches.items():
        ck.flag(v, f"synthetic.switches.{k}")
    values = {k: ck.number(v, f"synthetic.parameters.{k}") for k, v in params.items()}
    for k in study.free:
        if k not in values:
            raise StudyError(f"{study.path}: synthetic.parameters.{k} is missing: the generator needs a value for "
                             "every free parameter")
    for k in values:
        if k not in study.spec.parameters:
            ck.fail(f"synthetic.parameters.{k}", params[k], f"unknown parameter of {study.model}")
    out = {"parameters": values, "switches": switches,
           "noise": ck.number(s.get("noise", SYNTHETIC_DEFAULTS["noise"]) if noise is None else noise,
                              "synthetic.noise", non_negative=True),
           "seed": ck.integer(s.get("seed", SYNTHETIC_DEFAULTS["seed"]) if seed is None else seed, "synthetic.seed", 0),
           "points": ck.integer(s.get("points", SYNTHETIC_DEFAULTS["points"]), "synthetic.points", 3),
           "max_strain_pct": s.get("max_strain_pct")}
    if out["max_strain_pct"] is not None:
        ck.number(out["max_strain_pct"], "synthetic.max_strain_pct", positive=True)
    return out


def synthetic_abscissae(spec: TestSpec, settings: dict):
    """Recorded abscissae of a generated test: axial or cavity strain (%) evenly spaced to the largest strain, or
    the driver's own log-spaced hold times (s since the test start) of an incremental oedometer."""
    if spec.type == "oedometer_creep":
        hold = np.geomspace(spec.load_time, spec.stage_duration, spec.n_times)
        return np.concatenate([k * spec.stage_duration + hold for k in range(len(spec.stage_stress))])
    top = min(settings["max_strain_pct"] or MAX_STRAIN_PCT[spec.type], MAX_STRAIN_PCT[spec.type])
    n = settings["points"]
    x = np.linspace(top / n, top, n)
    return -x if spec.type == "triaxial" and spec.direction == "extension" else x


def generate(path, noise=None, seed=None, directory=None) -> dict:
    """Write SYNTHETIC recordings of every test of the study file ``path`` from its [synthetic] table: this project's
    forward model (the lab drivers or the SBP FE at the study's FE settings, full preset) at the stated parameter
    values, times independent multiplicative noise c ~ N(1, noise^2) per point and curve (Eq. 1). Files go to the
    paths the study names (or into ``directory`` with the same file names). Returns {test: path}."""
    study = load_study(path, check_files=False)
    settings = synthetic_settings(study, noise, seed)
    fake = {}
    for spec in study.tests:
        x = synthetic_abscissae(spec, settings)
        quantities = generated_quantities(spec)
        fake[spec.name] = inference.Test(spec.name, {CURVE_OF.get(q, q): inference.Curve(x, np.ones_like(x))
                                                     for q in quantities})
    observations = inference.Observations(list(fake.values()))
    forward = StudyForward(replace(study, fixed={**study.fixed, **{k: v for k, v in settings["parameters"].items()
                                                                   if k not in study.free}}),
                           observations, settings["switches"])
    free = {k: v for k, v in settings["parameters"].items() if k in study.free}
    result = forward([free])[0]
    if isinstance(result, Exception):
        raise RuntimeError(f"the generating model failed: {result}")
    rng = np.random.default_rng(settings["seed"])
    paths = {}
    for spec in study.tests:
        t = fake[spec.name]
        x = next(iter(t.curves.values())).x
        x_name = X_COLUMN[spec.type]
        columns = {_column(x_name, spec.type): x}
        for q in generated_quantities(spec):
            sim = result[spec.name][CURVE_OF.get(q, q)]
            y = np.interp(x, *sim) if isinstance(sim, tuple) else np.asarray(sim)
            columns[_column(q, spec.type)] = y * rng.normal(1.0, settings["noise"], y.size)
        if spec.type == "sbp":
            columns["time_s"] = x / 100.0 / spec.strain_rate
        header = [f"synthetic: NOT MEASURED DATA. Generated by cases.calibrate.generate from {Path(path).name} with "
                  f"this project's forward model {class_name(settings['switches'], study.model)}",
                  f"synthetic_parameters: {json.dumps(free)}",
                  f"synthetic_fixed: {json.dumps(forward.fixed)}",
                  f"synthetic_noise: multiplicative c ~ N(1, {settings['noise']:g}^2) per point on every value column "
                  f"(Eq. 1), seed {settings['seed']}",
                  f"test: {spec.name}", f"test_type: {spec.type}: {spec.describe()}"]
        if spec.type == "sbp":
            fe = {k: getattr(forward.sbp[spec.name].preset, k) for k in FE_FIELDS}
            header.append(f"synthetic_fe: {json.dumps(fe)}")
        target = Path(directory) / spec.file.name if directory else spec.file
        target.parent.mkdir(parents=True, exist_ok=True)
        paths[spec.name] = write_records(target, header, columns, exact=(_column(x_name, spec.type),))
    return paths


# ====================================================================================================================
# Command line
# ====================================================================================================================
def _options(ap):
    ap.add_argument("study", type=Path, help="the study file (TOML)")
    ap.add_argument("--diagnose", action="store_true", help="run the whole missing-physics loop")
    ap.add_argument("--generate", action="store_true", help="(re)write the study's SYNTHETIC CSVs from its "
                    "[synthetic] table and exit")
    ap.add_argument("--noise", type=float, help="with --generate: the noise level (default: the [synthetic] table's)")


def prepare(args) -> tuple:
    """Everything checked before any solve: (Study, Observations, StudyProblem, Settings). Raises StudyError or
    DataError."""
    study_ = load_study(args.study)
    observations, times = load_observations(study_)
    problem = StudyProblem(study_, observations, times, args.quick, args.processes, args.dispatch)
    return study_, observations, problem, study_.settings(args.quick, args.samples)


def main(argv=None):
    args = study.arguments(__doc__, argv, quick_help="the study's [sampler.quick] and [fe.quick] settings",
                           add=_options)
    try:
        if args.generate:
            paths = generate(args.study, noise=args.noise)
            print(json.dumps({k: str(v) for k, v in paths.items()}))
            return 0
        study_, observations, problem, settings = prepare(args)
        if args.diagnose and inference.executors.mpi_world() is not None:
            raise StudyError("--diagnose runs without mpirun (use --processes for a local pool)")
    except (StudyError, DataError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    default_out = DEFAULT_OUT / study_.name
    if args.diagnose:
        for run_args, seed, out in study.run_directories(args, default_out):
            d = run_loop(observations, run_args, out, seed, settings, f"study {study_.name}, seed {seed}", problem)
            print(json.dumps({"case": CASE, "study": study_.name, "out": str(out), "verdict": d["verdict"],
                              "omitted_physics": d["omitted_physics"], "log_bayes": d["log_bayes"],
                              "timing": d["timing"]}, default=float), flush=True)
        return 0
    name = class_name(study_.switches, study_.model)
    like = inference.Likelihood(observations, problem.forward(study_.switches), batch=True)
    prior = problem.prior(study_.free, study_.log_uniform)

    def finish(run_args, seed, out, post):
        return finish_class(post, like, problem, name, study_.switches, run_args, out, seed,
                            settings.predictive_draws, post.wall_s)[2]

    study.run_all(args, default_out, like, prior, settings.n_samples, {"max_steps": settings.max_steps}, finish)
    return 0


if __name__ == "__main__":
    sys.exit(main())
