"""Model-form-only controls of the independent generator: the plain clay (Modified Cam Clay, no physical effect) written
with another team's conventions, so that a diagnosis that confirms an effect on them mistakes a model-form difference
for missing physics.

Each variant of :data:`CONTROLS` changes one convention (or several) of the generator's own models, integrator,
logging or cavity solution; everything else is the clay of :mod:`validation.independent.programmes`
(:data:`~validation.independent.programmes.CLAY`; the variants that read lambda and kappa differently carry the values a
team using that convention would have fitted to the same clay, so that the difference left is the convention's shape,
a few %, not a gross offset):
- ``v_initial``: specific volume held at the specimen's 1 + e0 in the elastic and hardening laws (ln p' linear in the
  volumetric strain); lambda 0.268, kappa 0.054 (the reference's lambda, kappa times v0/v of the mid-range,
  :data:`V_INITIAL` / :data:`V_MID`);
- ``lnv``: ln(1 + e)-ln p' compression and swelling (Butterfield 1979), lambda* 0.118, kappa* 0.024 (lambda, kappa
  over :data:`V_MID`);
- ``constant_G`` (triaxial, pressuremeter): a constant shear modulus instead of a constant Poisson's ratio, per test
  the reference's value where its shearing starts (:func:`form`: 5040 kPa at p' 200 kPa, ..., 1220 kPa at the
  pressuremeter's in situ p' 48 kPa); over the two decades of stress of an oedometer a constant G is a gross
  difference (11-30 % measured), not a convention, so it is not written there;
- ``k0_jaky`` / ``k0_mcc``: the oedometer specimen's initial K0 and the in situ preconsolidation line from Jaky's
  1 - sin phi' (0.50) or the Modified Cam Clay flow rule (0.64) instead of the stated 0.55;
- ``coarse_explicit``: the explicit integrator with sub-steps 50 times coarser (1e-3 strain, 2 % of p' per stress
  step): its first-order drift;
- ``sparse_log``: logging three times sparser in strain, one point per decade in holds, stresses read to 1 kPa;
- ``exact_cavity`` (pressuremeter): the fast, nearly undrained expansion by the exact large-strain undrained
  strain-path solution (:mod:`validation.independent.sbp_exact`) instead of the small-strain consolidation solver,
  its hold the solver's hold with the excess pressures scaled to the exact ones at the end of the expansion; the slow
  test by the consolidation solver on a coarse grid (25 elements to 100 a0, steps of 5e-4 cavity strain);
- ``reference``: our own conventions, written for the two CRS programmes below that have no other control.
:data:`APPLIES` lists the variants written per programme (where the convention changes the records: e.g. no K0
variant on isotropically consolidated specimens or the pressuremeter's measured K0). :func:`difference` measures each
variant's size: the RMS relative difference of its noise-free records from the reference conventions' at the same
logged points (stresses and pore pressures above 5 kPa; axial strains above 0.5 % where they are a response), in %
as measured (seed 1's points; max over the columns): v_initial and lnv 1-3 (triaxial q, u; crs_load, crs_ur
sigma'_v), 4.5-6.7 (crs and relaxation: their unloading to low stress), 5.7 (il, settlement); constant_G 1-2 (q, u;
ck0u's axial strain in K0 consolidation 13), 1.0/1.5 (sbp total pressure / pore pressure; 3/6-7 of their excesses
over the in situ values); k0_jaky, k0_mcc 1-2.7; coarse_explicit 0.2-0.7; sparse_log 0.2-1.2 (the 1-kPa reading, on
fewer points; il only fewer points); exact_cavity 1.0/0.7 (total pressures; 3.3/3.5 of the excesses in the fast
test, up to 14 % in the wall pore pressure's early expansion).

Programmes added for the controls (:data:`CONTROL_PROGRAMMES`; kPa, 1/s, strains in %): ``crs_load``, CRS at 1e-6
1/s to 20 % (loading only); ``crs_ur``, CRS at 1e-6 1/s to 10 %, unloading to sigma'_v 50 kPa, reloading to 20 %.

Files: opaque case ids ``<programme>_<letter>_s<seed>`` with letters after the programme's effect cases (E onwards for
the laboratory programmes, C onwards for sbp, A onwards for the new ones), shuffled per programme; headers and study
files as the effect cases' (they name neither the variant nor that the case is a control); the truth in KEY.json with
``"effect": "none"`` and ``"model_form": <variant>``.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .programmes import CLAY, PROGRAMMES, Stage, Test
from .recording import SEEDS, header, write_csv
from .recording import records as lab_records
from .recording import study_text as lab_study
from .sbp import PROGRAMME as SBP
from .sbp import TESTS as SBP_TESTS
from .sbp import cavity_clay
from .sbp import header as sbp_header
from .sbp import records as sbp_records
from .sbp import simulate as sbp_simulate
from .sbp import study_text as sbp_study
from .sbp_exact import strain_path_expansion

__all__ = ["CONTROLS", "APPLIES", "CONTROL_PROGRAMMES", "case_ids", "shear_start", "form", "records", "difference",
           "write_controls"]

#: the specific volume of the clay's mid-range in the oedometer (1 + e at sigma'_v about 150 kPa) and the specimens'
#: initial one, by which the variants reading v differently carry the reference's lambda, kappa
V_MID, V_INITIAL = 2.12, 2.27
CONTROLS = {
    "reference": {},
    "v_initial": {"conventions": {"specific_volume": "initial"},
                  "clay": {"lambda_": 0.25 * V_INITIAL / V_MID, "kappa": 0.05 * V_INITIAL / V_MID}},
    "lnv": {"conventions": {"compression": "lnv-lnp"}, "clay": {"lambda_": 0.25 / V_MID, "kappa": 0.05 / V_MID}},
    "constant_G": {"conventions": {"elasticity": "G", "G": "at shear start"}},
    "k0_jaky": {"k0": "jaky"},
    "k0_mcc": {"k0": "mcc"},
    "coarse_explicit": {"steps": {"max_strain": 1e-3, "max_stress": 2e-2}},
    "sparse_log": {"logging": {"spacing": 3.0, "per_decade": 1, "resolution": 1.0}},
    "exact_cavity": {"cavity": "exact", "solver": {"n": 25, "outer": 100.0, "max_strain": 5e-4}},
}


def _crs_load(e0):
    return Test("CRS", "oedometer", {"sigma_v0": 20.0, "K0": 0.55, "e0": e0},
                (Stage("crs", "loading1", {"strain_rate": 1e-6, "to_axial_strain": 20.0}, "strain"),))


def _crs_ur(e0):
    return Test("CRS_ur", "oedometer", {"sigma_v0": 20.0, "K0": 0.55, "e0": e0},
                (Stage("crs", "loading1", {"strain_rate": 1e-6, "to_axial_strain": 10.0}, "strain"),
                 Stage("crs", "unloading2", {"strain_rate": -1e-6, "to_sigma_v": 50.0}, "strain"),
                 Stage("crs", "reloading3", {"strain_rate": 1e-6, "to_axial_strain": 20.0}, "strain")))


#: programme -> (description for the headers, its tests), as :data:`validation.independent.programmes.PROGRAMMES`
CONTROL_PROGRAMMES = {
    "crs_load": ("constant-rate-of-strain oedometer at 1e-6 1/s to 20 % axial strain", (_crs_load(1.27),)),
    "crs_ur": ("constant-rate-of-strain oedometer at 1e-6 1/s: loading to 10 %, unloading to sigma'_v 50 kPa, "
               "reloading to 20 %", (_crs_ur(1.26),)),
}
_LAB = ("v_initial", "lnv", "coarse_explicit", "sparse_log")
_TRIAXIAL = _LAB + ("constant_G",)
_OEDOMETER = _LAB + ("k0_jaky", "k0_mcc")
#: programme -> the variants written for it
APPLIES = {"ciu": _TRIAXIAL, "ck0u": _TRIAXIAL, "crs": _OEDOMETER, "il": _OEDOMETER, "relaxation": _OEDOMETER,
           "crs_load": ("reference",) + _OEDOMETER, "crs_ur": ("reference",) + _OEDOMETER,
           SBP: ("constant_G", "exact_cavity")}
#: the noise and logging streams of each programme (the effect cases' for the existing ones)
_STREAM = {**{p: k for k, p in enumerate(PROGRAMMES)}, SBP: len(PROGRAMMES), "crs_load": 10, "crs_ur": 11}
_FIRST_LETTER = {**{p: 4 for p in PROGRAMMES}, SBP: 2, "crs_load": 0, "crs_ur": 0}


def _tests(programme):
    if programme == SBP:
        return SBP_TESTS
    return {**PROGRAMMES, **CONTROL_PROGRAMMES}[programme][1]


def case_ids() -> dict:
    """{(programme, variant): opaque letter}: a fixed shuffle per programme of the letters after its effect cases'."""
    out = {}
    for k, (prog, variants) in enumerate(APPLIES.items()):
        order = np.random.default_rng(4040 + k).permutation(len(variants))
        for variant, j in zip(variants, order):
            out[prog, variant] = chr(ord("A") + _FIRST_LETTER[prog] + int(j))
    return out


def _sbp_simulated(test, f):
    """(spans, rows) of an SBP test under a variant: the exact strain-path expansion for the fast test and the coarse
    solver for the slow one (``exact_cavity``), or the solver with the variant's conventions."""
    conventions = f.get("conventions")
    if f.get("cavity") != "exact":
        return sbp_simulate(test, "none", conventions=conventions)
    if test is not SBP_TESTS[0]:
        return sbp_simulate(test, "none", **f["solver"])
    spans, rows = sbp_simulate(test, "none")
    material, size = cavity_clay(test, "none")
    init, f = test.initial, test.stages[0].fields
    sh = init["K0"] * init["sigma_v0"]
    exact = strain_path_expansion(material, (sh, sh, init["sigma_v0"]), size, 1.0 + init["e0"], 0.0415, init["u0"],
                                  f["strain_rate"], f["to_cavity_strain"] / 100.0)
    a, b = spans[test.stages[1].name]
    hold = rows[a:b].copy()
    for j, rest in ((2, sh + init["u0"]), (3, init["u0"])):
        hold[:, j] = rest + (hold[:, j] - rest) * (exact[-1, j] - rest) / (hold[0, j] - rest)
    hold[:, 0] += exact[-1, 0] - hold[0, 0]
    n = len(exact)
    return ({test.stages[0].name: (0, n), test.stages[1].name: (n - 1, n - 1 + len(hold))},
            np.concatenate([exact, hold[1:]]))


def records(programme, variant, seed, test_index) -> dict:
    """{column: values} of one test of ``programme`` under ``variant`` for a noise seed, as written in its file."""
    test = _tests(programme)[test_index]
    f = form(variant, test)
    if programme == SBP:
        return sbp_records(test, "none", seed, test_index, _sbp_simulated(test, f))
    return lab_records(test, "none", seed, _STREAM[programme], test_index, f)


def _sbp_noise_free(test, f, seed, test_index):
    spans, rows = _sbp_simulated(test, f)
    rec = sbp_records(test, "none", seed, test_index, (spans, rows))
    t = rec["time_s"]
    return {"stage": rec["stage"], "stage_time_s": rec["stage_time_s"], "cavity_strain_pct": rec["cavity_strain_pct"],
            "cavity_pressure_kPa": np.interp(t, rows[:, 0], rows[:, 2]),
            "pore_pressure_kPa": np.interp(t, rows[:, 0], rows[:, 3])}


def shear_start(test) -> float:
    """Mean effective stress (kPa) where the test's shearing starts: the last consolidation target of a triaxial test,
    the in situ state of a pressuremeter."""
    stage = [s.fields for s in test.stages if s.kind == "consolidation"][-1] if test.apparatus == "triaxial" else None
    if stage is None:
        return test.initial["sigma_v0"] * (1.0 + 2.0 * test.initial["K0"]) / 3.0
    return stage["p"] if "p" in stage else stage["sigma_v"] * (1.0 + 2.0 * stage["K0"]) / 3.0


def form(variant, test) -> dict:
    """The variant's options for one test: a constant G given as "at shear start" becomes the reference's
    constant-nu G (Eq. 1 of the models) at :func:`shear_start` and v = :data:`V_MID`: 3 v p' (1 - 2 nu) /
    (2 (1 + nu) kappa), kPa."""
    f = dict(CONTROLS[variant])
    conventions = f.get("conventions", {})
    if conventions.get("G") == "at shear start":
        nu, kappa = CLAY["nu"], CLAY["kappa"]
        G = 3.0 * V_MID * shear_start(test) * (1.0 - 2.0 * nu) / (2.0 * (1.0 + nu) * kappa)
        f["conventions"] = {**conventions, "G": round(G, -1)}
    return f


def _aligned(test, a, b, column):
    """``a[column]`` at ``b``'s logged points (per stage, by axial strain in strain-logged stages, else by stage
    time) and the mask of ``b``'s points compared (|value| above 5 kPa; for the axial strain, above 0.5 % where it is
    a response: consolidation, hold and load stages)."""
    out = np.full(len(b[column]), np.nan)
    for k, stage in enumerate(test.stages, start=1):
        ia, ib = a["stage"] == k, b["stage"] == k
        x = "axial_strain_pct" if stage.log == "strain" else "stage_time_s"
        x = "cavity_strain_pct" if x not in a else x
        order = np.argsort(a[x][ia])
        out[ib] = np.interp(b[x][ib], a[x][ia][order], a[column][ia][order])
    if column == "axial_strain_pct":
        response = np.array([test.stages[int(k) - 1].kind in ("consolidation", "creep", "load") for k in b["stage"]])
        return out, response & (np.abs(b[column]) > 0.5)
    return out, np.abs(b[column]) > 5.0


def difference(programme, variant, seed=1) -> dict:
    """{column: RMS relative difference} of the variant's noise-free records from the reference conventions' at the
    same logged points (:func:`_aligned`), over the programme's tests; the reference is read with the variant's
    logging points but not its stress resolution."""
    out = {}
    for ti, test in enumerate(_tests(programme)):
        f = form(variant, test)
        logging = {k: v for k, v in f.get("logging", {}).items() if k != "resolution"}
        reference = {"logging": logging} if logging else {}
        if programme == SBP:
            a, b = (_sbp_noise_free(test, g, seed, ti) for g in (f, reference))
        else:
            a, b = (lab_records(test, "none", seed, _STREAM[programme], ti, g, 0.0) for g in (f, reference))
        for column in b:
            if column.endswith("kPa") or column == "axial_strain_pct":
                value, keep = _aligned(test, a, b, column)
                if keep.any():
                    out.setdefault(column, []).append(value[keep] / b[column][keep] - 1.0)
    return {c: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for c, v in out.items()}


def write_controls(folder, seeds=SEEDS) -> dict:
    """Write every control case (programme x variant x seed) under ``folder`` and add their truth to its
    ``KEY.json`` (the other entries kept); returns the controls' part of the key."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    letters, key = case_ids(), {}
    for prog, variants in APPLIES.items():
        tests = _tests(prog)
        for variant in variants:
            simulated = {}
            for seed in seeds:
                case = f"{prog}_{letters[prog, variant]}_s{seed}"
                d = folder / case
                d.mkdir(exist_ok=True)
                for ti, test in enumerate(tests):
                    if prog == SBP:
                        if test.name not in simulated:
                            simulated[test.name] = _sbp_simulated(test, form(variant, test))
                        write_csv(d / f"{test.name}.csv", sbp_header(case, test, seed),
                                  sbp_records(test, "none", seed, ti, simulated[test.name]))
                    else:
                        desc = {**PROGRAMMES, **CONTROL_PROGRAMMES}[prog][0]
                        write_csv(d / f"{test.name}.csv", header(case, desc, test, seed),
                                  records(prog, variant, seed, ti))
                text = sbp_study(case) if prog == SBP else lab_study(case, desc, tests)
                (d / "study.toml").write_text(text)
                key[case] = {"programme": prog, "effect": "none", "model_form": variant, "seed": seed,
                             "parameters": {**CLAY, **CONTROLS[variant].get("clay", {})},
                             "conventions": {t.name: {k: v for k, v in form(variant, t).items() if k != "clay"}
                                             for t in tests}}
    path = folder / "KEY.json"
    full = json.loads(path.read_text()) if path.is_file() else {}
    full = {c: v for c, v in full.items() if "model_form" not in v} | key
    path.write_text(json.dumps(full, indent=1, sort_keys=True) + "\n")
    return key
