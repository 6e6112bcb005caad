"""Concealed-effect proofs: a programme of SYNTHETIC tests whose data a generating model class made (stated in the
proof's code, never in the data files), a base class that lacks one effect, and the calibrate -> diagnose loop that
must name the effect without being told.

A :class:`Programme` is data: the test records (``cases.study.programme.TestSpec``), each test's recorded strains
(-, the exact values the forward model runs at) and curves, and the conditions written into the file headers.
:func:`synthetic_curves` runs the generating class through the laboratory forward model and multiplies every value by
independent noise c ~ N(1, noise^2) (Eq. 1); :func:`write_data` and :func:`load_data` write and read the shipped CSVs
(one per test, headers naming only the test conditions); :class:`ProgrammeProblem` is the loop's problem (base class,
forward model per class, covariates, figure) for a laboratory programme.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

import inference
from cases.study.forward.lab import LabForward
from cases.study.loop.covariates import programme_covariates
from cases.study.loop.problem import LoopProblem
from cases.study.outputs.report import plot_loop
from cases.study.reading.records import write_records
from cases.study.reading.schema import Settings

__all__ = ["PRESETS", "Programme", "test_kind", "synthetic_curves", "observations_from", "write_data", "load_data",
           "ProgrammeProblem", "SYNTHETIC_LINE"]

#: the first header line of every shipped proof file
SYNTHETIC_LINE = ("synthetic: NOT MEASURED DATA. Generated with constitutive.labtests from a generating model stated "
                  "in validation/proofs/ (its --generate option); the file does not name it")
#: class calibration sizes of the laboratory proofs
PRESETS = {"paper": Settings(400, 8, 100), "quick": Settings(200, 5, 60)}
#: recorded curve -> CSV column quantity (all in kPa)
COLUMNS = {"q": "q", "p": "p", "axial_stress": "sigma_v", "radial_stress": "sigma_r"}


def test_kind(spec) -> str:
    """The laboratory's short name of a test: CK0UC, CIUE, ... (consolidation, drainage, direction) or CRS."""
    if spec.type == "oedometer_crs":
        return "CRS"
    return (f"C{'K0' if spec.consolidation == 'K0' else 'I'}{'U' if spec.drainage == 'undrained' else 'D'}"
            f"{'C' if spec.direction == 'compression' else 'E'}")


@dataclass(frozen=True)
class Programme:
    """Laboratory tests (TestSpec), their recorded axial strains {test: (n,) signed, -} and curves {test: names},
    and the header conditions {test: {key: value}} of their files."""

    tests: tuple
    strains: dict
    curves: dict
    conditions: dict

    def forward(self, fixed: dict, switches: dict) -> LabForward:
        """The batched forward model of the class with ``switches`` (the void ratio a parameter, ANICREEP-style)."""
        return LabForward("ANICREEP", self.tests, self.strains, self.curves, fixed, switches, e0_parameter=True)

    def test(self, name):
        return next(t for t in self.tests if t.name == name)


def synthetic_curves(programme: Programme, fixed: dict, switches: dict, values: dict, seed_sequence, noise: float):
    """{test: {curve: recorded values}} of the generating class (``switches``, parameter ``values``) times
    c ~ N(1, noise^2) per point, drawn test by test and curve by curve from ``SeedSequence(seed_sequence)``."""
    curves, failed = programme.forward(fixed, switches).simulate({k: np.array([v]) for k, v in values.items()})
    if any(f[0] for f in failed.values()):
        raise RuntimeError(f"generating model failed: {failed}")
    rng = np.random.default_rng(np.random.SeedSequence(seed_sequence))
    return {t.name: {c: curves[t.name][c][0] * rng.normal(1.0, noise, programme.strains[t.name].size)
                     for c in programme.curves[t.name]} for t in programme.tests}


def observations_from(programme: Programme, curves: dict, label: str) -> inference.Observations:
    """In-memory observations of ``curves`` (:func:`synthetic_curves`), conditions as in the file headers."""
    return inference.Observations([
        inference.Test(t.name, {c: inference.Curve(100.0 * programme.strains[t.name], curves[t.name][c],
                                                   "axial_strain", COLUMNS[c], "%", "kPa")
                                for c in programme.curves[t.name]},
                       {"synthetic": label, **programme.conditions[t.name]}) for t in programme.tests])


def write_data(programme: Programme, directory, curves: dict, noise: float, seed: int) -> dict:
    """Write one CSV per test (axial strain in %, the curves in kPa); headers name only the test conditions.
    Returns {test: path}."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = {}
    for t in programme.tests:
        header = [SYNTHETIC_LINE, f"synthetic_noise: multiplicative c ~ N(1, {noise}^2) per point (Eq. 1), seed {seed}",
                  f"test: {t.name}", *(f"{k}: {v:.6g}" if isinstance(v, float) else f"{k}: {v}"
                                       for k, v in programme.conditions[t.name].items())]
        paths[t.name] = write_records(directory / f"{t.name}.csv", header, {
            "axial_strain_pct": 100.0 * programme.strains[t.name],
            **{f"{COLUMNS[c]}_kPa": curves[t.name][c] for c in programme.curves[t.name]}})
    return paths


def load_data(programme: Programme, directory) -> inference.Observations:
    """The shipped records of ``directory`` (one CSV per test); the strains must equal the programme's."""
    tests = []
    for t in programme.tests:
        path = Path(directory) / f"{t.name}.csv"
        obs = inference.Observations.from_csv({t.name: path}, x="axial_strain",
                                              curves={c: COLUMNS[c] for c in programme.curves[t.name]},
                                              units={"axial_strain": "%", **{COLUMNS[c]: "kPa" for c in COLUMNS}})
        x = next(iter(obs[t.name].curves.values())).x
        if not np.allclose(x, 100.0 * programme.strains[t.name], rtol=1e-6):
            raise inference.DataError(f"{path}: axial strains differ from the test grid")
        tests.append(obs[t.name])
    return inference.Observations(tests)


class ProgrammeProblem(LoopProblem):
    """A laboratory proof as the loop's problem: ANICREEP classes with ``fixed`` values on the ``programme``, the
    base class ``base_switches`` with ``base_bounds`` and sigma_eps free; covariates of
    :func:`cases.study.loop.covariates.programme_covariates` plus ``extra_covariates(like, map_curves)``."""

    model = "ANICREEP"

    def __init__(self, case: str, programme: Programme, fixed: dict, base_switches: dict, base_bounds: dict,
                 description: str, extra_covariates=None, sigma_bounds=None):
        self.case, self.programme, self.fixed = case, programme, dict(fixed)
        self.base_switches, self.base_bounds = dict(base_switches), dict(base_bounds)
        if sigma_bounds is not None:
            self.sigma_bounds = dict(sigma_bounds)
        self.text, self.extra_covariates = description, extra_covariates

    def forward(self, switches):
        return self.programme.forward(self.fixed, switches)

    def map_curves(self, params, switches):
        """The MAP's simulated quantities of every test, with its overconsolidation sigma'_p0 / sigma'_v0."""
        raw, _ = self.forward(switches).simulate({k: np.array([v]) for k, v in params.items()})
        out = {t: {c: v[0] for c, v in cs.items()} for t, cs in raw.items()}
        for t in self.programme.tests:
            out[t.name]["overconsolidation"] = params["sigma_p0"] / t.sigma_v0
        return out

    def curve_covariates(self, like, map_curves):
        cov = programme_covariates(self.programme.tests, like.observations, map_curves, strains=self.programme.strains)
        if self.extra_covariates is not None:
            cov.update(self.extra_covariates(like, map_curves))
        return cov

    def summary_extra(self, switches):
        return {"fixed": self.fixed, "synthetic": True}

    def describe(self, label, base_name):
        return f"**SYNTHETIC data** ({label}). Base class {base_name} with M, sigma'_p0, sigma_eps free; {self.text}"

    def plot(self, path, like, classes, diag, label):
        plot_loop(path, like, classes, diag, label, True)
