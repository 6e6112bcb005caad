"""Staged laboratory programmes (triaxial cell, oedometer) driven stage by stage through
``constitutive.labtests.mixed_control`` (step tables) or ``adaptive_control`` (the holds of a rate-dependent model,
:mod:`cases.study.forward.lab_stage_steps`), batched over particles (a model whose parameters are (n,) arrays) and over
the tests that share a stage structure (:func:`simulate_programmes`).

A test (:class:`cases.study.programme.TestSpec` with ``apparatus``, ``initial`` and ``stages``) starts from its
initial state and runs its stages in order; stress, model state, strain, excess pore pressure and time are carried
from one stage to the next. Units kPa, s, 1/s; strains are fractions, compression positive; axial = Voigt 11,
radial = 22 and 33. The controls, stepping and abscissae of each stage kind: :mod:`cases.study.forward.lab_stage_steps`;
a crs stage ended by ``to_sigma_v`` is continued here past its last record until sigma'_v reaches the target
(:func:`_to_sigma_v`: strain steps in chunks sized from the strain still needed, the crossing located within its step
by bracketing iterations). With a rate-dependent model the Newton iterations of a step-table stage start from the
previous step's increments (``mixed_control(predictor="previous")``).

Initial state per test (``InitialState``): effective stress ``p0`` (isotropic) or ``sigma_v0`` with ``K0``; void
ratio ``e0`` (else, where a stage gives the void ratio measured at its end, ``Stage.e_end``, the start that reaches
it, found per particle by :func:`_measured_start`; else the ``e0`` argument, else the model's own ``e0`` parameter);
for a
model whose void ratio is a parameter (ANICREEP: (1 + e0) enters its elasticity, hardening, fluidity mu, omega and the
void-ratio update) the test's e0 replaces that parameter for the test. Preconsolidation: ``preconsolidation``
(vertical, kPa) or ``ocr`` (relative to sigma'_v0, or p0 when isotropic); ANICREEP: sigma_p0 = preconsolidation
(= ocr sigma'_v0); Modified Cam Clay: ocr = preconsolidation / sigma'_v0, i.e. the yield surface through the initial
stress scaled by ocr (the surface through the stress ratio's preconsolidation state; for an isotropic start
p'_c0 = ocr p'_0); neither given: the model's parameter (MCC ocr/pc0, ANICREEP sigma_p0) applies. A model without a
preconsolidation state (SIMSAND) refuses them (ValueError).

A particle whose initial state is refused by the model or whose integration fails gets NaN curves and
``failed = True``; no exception for a particle, and a failed particle takes no further step.

Quantities (curve key ``<quantity>`` for a one-stage test, ``<quantity>@<stage name>`` otherwise; ``e`` and ``u``
are aliases of void_ratio and excess_pore_pressure): q (sigma'_a - sigma'_r, kPa), p (p', kPa), void_ratio,
volumetric_strain and axial_strain (% since the test start), excess_pore_pressure (kPa since the test start),
pore_pressure (u0 + excess, kPa), axial_stress, radial_stress (effective, kPa), time (s since the test start),
stress_ratio (q/p'), mean_stress (p').
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from cases.study.forward.lab_stage_steps import FALLBACK_STRAIN_STEP, StageSteps
from cases.study.programme import split_key
from cases.study.stages.base import OEDOMETER_STRAIN
from cases.study.stages.sequence import stage_spans
from constitutive import labtests
from constitutive.base import ParameterError

__all__ = ["simulate_programme", "simulate_programmes", "stage_signature", "specimen_model", "QUANTITIES", "ALIASES",
           "CROSSING_ITERATIONS", "CROSSING_TOLERANCE", "CHUNKS", "CHUNK_STEPS", "VOID_RATIO_TOLERANCE",
           "VOID_RATIO_ITERATIONS"]

QUANTITIES = ("q", "p", "void_ratio", "volumetric_strain", "axial_strain", "excess_pore_pressure", "pore_pressure",
              "axial_stress", "radial_stress", "time", "stress_ratio", "mean_stress")
ALIASES = {"e": "void_ratio", "u": "excess_pore_pressure", "sigma_v": "axial_stress"}
#: a crs stage ended by to_sigma_v (:func:`_to_sigma_v`): |sigma'_v - to_sigma_v| / to_sigma_v at its end, the
#: bracketing iterations at most locating it within a strain step, the chunks of strain steps at most and the steps
#: at most in one chunk
CROSSING_TOLERANCE = 1e-9
CROSSING_ITERATIONS = 40
#: a programme whose void ratio is measured at the end of a stage (``Stage.e_end``, :func:`_measured_start`): the
#: largest miss of that void ratio, and the runs at most of the programme up to it, that find the start void ratio
VOID_RATIO_TOLERANCE = 1e-10
VOID_RATIO_ITERATIONS = 8
CHUNKS = 12
CHUNK_STEPS = 400


# ---------------------------------------------------------------------------------------------- the specimen
def specimen_model(model, initial, e0=None):
    """(the model for this specimen, its void ratio at the start) from the test's initial state (module
    docstring, "Initial state"). ``e0``: the void ratio when the test gives none (scalar or (n,))."""
    changes = {}
    start_e = initial.e0 if initial.e0 is not None else e0
    if model.void_ratio_parameter:
        if start_e is not None:
            changes["e0"] = start_e
        else:
            start_e = model.parameters()["e0"]
    if start_e is None:
        raise ValueError(f"{model.name}: the test gives no initial void ratio e0")
    pre = initial.preconsolidation
    if pre is None and initial.ocr is not None:
        pre = initial.ocr * initial.vertical
    if pre is not None:
        names = model.parameter_names
        if "sigma_p0" in names:
            changes["sigma_p0"] = pre
        elif "ocr" in names:
            changes.update(ocr=pre / initial.vertical, pc0=None)
        else:
            raise ValueError(f"{model.name} has no preconsolidation state: a test's ocr / preconsolidation does not "
                             f"apply")
    return (model.replaced(changes) if changes else model), start_e


def _initial_stress(initial, n):
    stress = np.zeros((n, 6))
    if initial.p0 is not None:
        stress[:, :3] = initial.p0
    else:
        stress[:, 0] = initial.sigma_v0
        stress[:, 1] = stress[:, 2] = initial.K0 * initial.sigma_v0
    return stress


def _particle(model, i):
    """The one-particle model of particle i of a batched model."""
    return model.replaced({k: (np.asarray(v)[i] if np.ndim(v) else v)
                            for k, v in model.parameters().items() if v is not None})


def _start_state(model, stress, e, n):
    """(state, why (n,) object array): the model's initial state; a particle whose start the model refuses gets the
    model's reason in ``why`` ("" for the others) and the state of an accepted one (its curves become NaN)."""
    e = np.broadcast_to(np.asarray(e, dtype=float), (n,))
    why = np.full(n, "", dtype=object)
    try:
        return model.initial_state(stress, e), why
    except (ValueError, ParameterError) as exc:
        if n == 1:
            why[0] = f"initial state refused: {exc}"
            return None, why
    for i in range(n):
        try:
            _particle(model, i).initial_state(stress[i:i + 1], e[i:i + 1])
        except (ValueError, ParameterError) as exc:
            why[i] = f"initial state refused: {exc}"
    refused = why != ""
    if np.all(refused):
        return None, why
    good = int(np.flatnonzero(~refused)[0])
    stress[refused] = stress[good]
    e = np.where(refused, e[good], e)
    trial = model.replaced({k: (np.where(refused, np.asarray(v)[good], v) if np.ndim(v) else v)
                             for k, v in model.parameters().items() if v is not None})
    state = trial.initial_state(stress, e)
    return state, why


# ---------------------------------------------------------------------------------------------- the programme
def _select(mask, a, b):
    """Per-particle choice between two arrays or state dicts: a where mask, else b."""
    if isinstance(a, dict):
        return {k: _select(mask, a[k], b[k]) for k in a}
    return np.where(mask.reshape((-1,) + (1,) * (np.ndim(a) - 1)), a, b)


def _advance(carried, hist, u_start, stage):
    """The carried specimen after a mixed_control history of ``stage`` (its end; a point that did not move keeps its
    values, and so does the strain, pore pressure and time of one that failed in it: finite values for the stage
    plans that follow, which it does not take; its reason is the integration's)."""
    moved = {"strain": carried["strain"] + hist["strain"][:, -1], "u": u_start + hist["pore_pressure"][:, -1],
             "t": carried["t"] + hist["time"][:, -1]}
    kept = _select(hist["failed"], {k: carried[k] for k in moved}, moved)
    out = {**carried, "stress": hist["final_stress"], "state": hist["state"], **kept}
    for i, why in hist["reasons"].items():
        out = _fail(out, np.arange(out["failed"].size) == i, f"stage {stage.name}: {why}")
    return out


def _fail(carried, mask, why):
    """The carried specimen with the particles ``mask`` (n,) failed, a particle keeping the first reason it got."""
    reasons = carried["why"].copy()
    reasons[mask & ~carried["failed"]] = why
    return {**carried, "failed": carried["failed"] | mask, "why": reasons}


def _strain_steps(model, carried, rate, steps, size, active, stage, stop=None):
    """``steps`` (K,) axial strain steps of ``size`` (n,) signed as ``rate`` (1/s, (n,)) with every strain controlled
    (oedometer), for the ``active`` (n,) particles, each taking its own number ``steps`` (n,) of them: one
    mixed_control call from the carried specimen. Returns (the carried specimen after it, the history)."""
    n = rate.size
    count = int(steps[active].max(initial=0))
    inc = np.zeros((count, n, 6))
    inc[:, :, 0] = np.sign(rate) * size
    dt = np.broadcast_to(size / np.abs(rate), (count, n))
    taking = active & (np.arange(count)[:, None] < steps[None])
    record = np.zeros(count, dtype=bool)
    record[-1] = True
    hist = labtests.mixed_control(model, carried["stress"], carried["state"], OEDOMETER_STRAIN, inc, dt,
                                  record=record, on_failure="nan", active=taking, stop=stop)
    return _advance(carried, hist, carried["u"], stage), hist


def _to_sigma_v(model, carried, rate, target, step, stage):
    """Continue a crs stage (oedometer, every strain controlled) until sigma'_v reaches ``target`` (kPa, (n,)) at
    the axial strain rate ``rate`` (1/s, (n,), signed): the stage ends at the later of its last record and the
    crossing (a particle whose sigma'_v has reached or passed the target, in the direction the rate drives it, by
    the last record ends there).

    In chunks, each one mixed_control call of axial strain steps of ``step`` stopped before the step that would pass
    the target (``mixed_control(stop=...)``): the first chunk one step, the next ones 1.25 times the strain still
    needed estimated from the secant d ln sigma'_v / d eps_a of the chunk before (at most ``CHUNK_STEPS``). The
    crossing within the step it stopped before is located by Illinois iterations on the fraction of that step (each
    a one-step call from the state before it) to ``CROSSING_TOLERANCE`` relative. A particle whose sigma'_v does not
    move toward the target, leaves the positive range, or has not reached the target after ``CHUNKS`` chunks
    fails (a zero-likelihood particle), as does one whose integration fails."""
    n = rate.size
    direction = np.sign(rate)  # an oedometer's sigma'_v rises with its axial strain
    going = ~carried["failed"] & (direction * (target - carried["stress"][:, 0]) > 0.0)
    steps = np.ones(n, dtype=int)
    size = np.full(n, float(step))
    for _ in range(CHUNKS):
        if not going.any():
            break
        before = carried["stress"][:, 0]
        moved, hist = _strain_steps(model, carried, rate, steps, size, going, stage, (0, target, direction))
        carried = _select(going, moved, carried)
        at = going & hist["stopped"] & ~moved["failed"]
        if at.any():
            carried = _cross(model, carried, rate, target, size, at, hist["stop_value"], stage)
        going &= ~at & ~moved["failed"]
        now = carried["stress"][:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = direction * np.log(now / before) / (steps * size)  # d ln sigma'_v per unit strain, toward it
            need = direction * np.log(target / now) / slope
        stuck = going & ~(np.isfinite(need) & (slope > 0.0) & (now > 0.0))
        carried = _fail(carried, stuck, f"stage {stage.name}: sigma'_v does not move toward to_sigma_v "
                                        f"(or leaves the positive range) past the last record")
        going &= ~stuck
        steps = np.clip(np.ceil(1.25 * np.where(going, need, 0.0) / size), 1, CHUNK_STEPS).astype(int)
    return _fail(carried, going, f"stage {stage.name}: to_sigma_v not reached in {CHUNKS} chunks of strain steps "
                                 f"past the last record")


def _log_ratio(stress, target):
    """ln(stress / target), NaN where the stress is not positive (the iterations then bisect)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(np.where(stress > 0.0, stress, np.nan) / target)


def _cross(model, carried, rate, target, size, at, reached, stage):
    """The ``at`` particles (n,) taken from their state to the point of the next strain step of ``size`` where
    sigma'_v equals ``target``; ``reached`` (n,) their sigma'_v at the end of the whole step. Illinois iterations
    on the step's fraction, on ln sigma'_v (linear in the fraction where the step is elastic: MCC's p' is exponential
    in the volumetric strain)."""
    lo, hi = np.zeros(rate.size), np.ones(rate.size)
    g_lo, g_hi = _log_ratio(carried["stress"][:, 0], target), _log_ratio(reached, target)
    result, open_ = carried, at.copy()
    side = np.zeros(rate.size)  # the side moved last: -1 lo, +1 hi
    ones = np.ones(rate.size, dtype=int)
    for _ in range(CROSSING_ITERATIONS):
        with np.errstate(divide="ignore", invalid="ignore"):
            f = np.where(g_hi == 0.0, 1.0, lo - g_lo * (hi - lo) / (g_hi - g_lo))
        f = np.where(np.isfinite(f), np.clip(f, lo, hi), 0.5 * (lo + hi))
        trial, _ = _strain_steps(model, carried, rate, ones, f * size, open_, stage)
        g = _log_ratio(trial["stress"][:, 0], target)
        done = open_ & ((np.abs(g) <= CROSSING_TOLERANCE) | trial["failed"])
        result = _select(done, trial, result)
        open_ &= ~done
        if not open_.any():
            break
        high = np.sign(g) == np.sign(g_hi)
        g_lo = np.where(high & (side > 0), 0.5 * g_lo, g_lo)  # Illinois: halve the value kept twice
        g_hi = np.where(~high & (side < 0), 0.5 * g_hi, g_hi)
        hi, g_hi = np.where(high, f, hi), np.where(high, g, g_hi)
        lo, g_lo = np.where(high, lo, f), np.where(high, g_lo, g)
        side = np.where(high, 1.0, -1.0)
        result = _select(open_, trial, result)  # the last iterate where the iterations run out
    return result


def _quantities(hist, carried, u_start, u0):
    """Named quantities (n, R) of a stage's recorded history, in the units of the module docstring."""
    s = hist["stress"]
    strain = carried["strain"][:, None] + hist["strain"]
    axial, radial = s[..., 0], 0.5 * (s[..., 1] + s[..., 2])
    q, p = axial - radial, s[..., :3].mean(axis=-1)
    u = u_start[:, None] + hist["pore_pressure"]
    return {"q": q, "p": p, "void_ratio": hist["void_ratio"],
            "volumetric_strain": 100.0 * strain[..., :3].sum(axis=-1), "axial_strain": 100.0 * strain[..., 0],
            "excess_pore_pressure": u, "pore_pressure": u0 + u, "axial_stress": axial, "radial_stress": radial,
            "time": carried["t"][:, None] + hist["time"], "stress_ratio": q / p, "mean_stress": p}


def _keys_by_stage(spec, keys):
    """{stage name: [curve keys]} (a key without a stage belongs to the only stage of a one-stage test)."""
    out = {s.name: [] for s in spec.stages}
    for key in keys:
        quantity, stage = split_key(key)
        if stage is None:
            if len(spec.stages) != 1:
                raise ValueError(f"test {spec.name}: curve {key!r} names no stage (<quantity>@<stage name>)")
            stage = spec.stages[0].name
        if stage not in out:
            raise ValueError(f"test {spec.name}: curve {key!r}: no stage {stage!r}")
        if ALIASES.get(quantity, quantity) not in QUANTITIES:
            raise ValueError(f"test {spec.name}: curve {key!r}: unknown quantity {quantity!r} (known: "
                             f"{', '.join(QUANTITIES + tuple(ALIASES))})")
        out[stage].append(key)
    return out


def stage_signature(stage) -> tuple:
    """What lets stages of several tests share one mixed_control call (with the apparatus): the kind, the drainage
    and whether the stage continues to sigma'_v (a crs stage; the control rows and the drainage of every step)."""
    return stage.kind, stage.drainage, stage.procedure.continues_to_stress(stage)


def simulate_programme(model, spec, abscissae: dict, n: int, e0=None):
    """Curves of a staged laboratory test for n particles (module docstring).

    model: a material-point model whose parameters are scalars or (n,) arrays; spec: TestSpec with ``apparatus``
    (triaxial | oedometer), ``initial`` and ``stages``; abscissae: {curve key: recorded abscissae} in the stage's
    abscissa unit (strain as a fraction, time in s since the stage start, stress in kPa); e0: the void ratio at the
    start when the test gives none (scalar or (n,)). Returns ({curve key: (n, len(x)) values}, failed (n,) bool);
    a failed particle's curves are NaN.
    """
    return simulate_programmes(model, [spec], [abscissae], n, e0)[0][:2]


def simulate_programmes(model, specs, abscissae, n: int, e0=None, strain_step=None) -> list:
    """:func:`simulate_programme` of several tests for the same n particles: a list of (curves, failed, why), one
    per test of ``specs`` (abscissae: one dict per test; why: the reason each particle failed, "" where it did
    not); ``strain_step``: the largest strain increment (-), default the model's ``max_strain_step`` (else
    :data:`FALLBACK_STRAIN_STEP`).

    Tests in the same apparatus (and whose specimen models have the same parameters set) run together over
    (tests x particles) points, in rounds: each round takes the next stage of the tests whose next stage has the most
    common :func:`stage_signature` (tests of the same stage sequence share every round; a test with a stage fewer
    waits one round), one driver call per round over the points of its tests. Each test keeps the steps it
    has alone (:class:`cases.study.forward.lab_stage_steps.StageSteps` of its own rows: its targets, rates, durations,
    records and initial state); the step tables of a round are aligned by step index, a shorter one padded at its end
    with steps its rows do not take (``mixed_control(active=...)``), and the states are stored at the union of the
    tests' record steps; an adaptive round (:func:`_adaptive`) chooses every point's steps from that point alone. Every
    point thus takes the same steps as in a call of its own: the curves equal the one-test results to round-off."""
    for spec in specs:
        if spec.apparatus not in ("triaxial", "oedometer"):
            raise ValueError(f"test {spec.name}: apparatus {spec.apparatus!r} is not a laboratory cell (triaxial, "
                             f"oedometer)")
    measured = [_measured_end(spec) for spec in specs]
    abscissae = [x if m is None else {**x, m[1]: np.array([m[2]])} for x, m in zip(abscissae, measured)]
    specs = [_measured_start(model, spec, x, n, e0, strain_step) for spec, x in zip(specs, abscissae)]
    prepared = [(spec, *specimen_model(model, spec.initial, e0)) for spec in specs]
    groups = {}
    for j, (spec, specimen, _) in enumerate(prepared):
        set_names = tuple(k for k, v in specimen.parameters().items() if v is not None)
        groups.setdefault((spec.apparatus, set_names), []).append(j)
    results = [None] * len(specs)
    for members in groups.values():
        done = _simulate_group([prepared[j] for j in members], [abscissae[j] for j in members], n, strain_step)
        for j, result in zip(members, done):
            results[j] = result
    for j, m in enumerate(measured):
        if m is not None:
            curves, failed, why = results[j]
            results[j] = ({c: v for c, v in curves.items() if c != m[1]}, failed, why)
    return results


def _measured_end(spec):
    """(stage index, curve key, the stage's end in its abscissa) of the stage of ``spec`` whose void ratio at its end
    was measured (``Stage.e_end``; the key the alias ``e@<stage>``, so that it adds to a recorded void ratio), or
    None."""
    k = next((k for k, s in enumerate(spec.stages) if s.e_end is not None), None)
    if k is None:
        return None
    stage = spec.stages[k]
    span = stage_spans(spec)[k].get(stage.abscissa)
    if span is None:
        raise ValueError(f"test {spec.name}: stage {stage.name}: the void ratio at its end (e_end) needs its end in "
                         f"{stage.abscissa} known before the solve")
    end = span[1] / 100.0 if stage.abscissa == "axial_strain" else span[1]
    return k, f"e@{stage.name}", end


def _measured_start(model, spec, abscissae, n, e0, strain_step):
    """``spec`` with the initial void ratio, per particle (n,), that reaches the void ratio measured at the end of
    its stage with ``e_end`` (:func:`_measured_end`; ``abscissae`` hold its key): the programme up to that stage,
    with the same records (hence the same steps as in the whole programme), simulated from e0 = e_end, then e0 moved
    by secant steps on the miss at the stage's end (the first step the miss itself: the change of e over the stage
    hardly depends on e0) until the miss is within VOID_RATIO_TOLERANCE or after VOID_RATIO_ITERATIONS runs;
    ``spec`` itself when no stage gives one. A particle whose run fails keeps its last start and fails again in the
    whole programme, with its reason."""
    measured = _measured_end(spec)
    if measured is None:
        return spec
    k, key, _ = measured
    stage = spec.stages[k]
    index = {s.name: j for j, s in enumerate(spec.stages)}
    head = replace(spec, stages=spec.stages[:k] + (replace(stage, e_end=None),))
    x = {c: v for c, v in abscissae.items() if index[split_key(c)[1] or spec.stages[0].name] <= k}
    start, before = np.full(n, stage.e_end), None
    for _ in range(VOID_RATIO_ITERATIONS):
        trial = replace(head, initial=replace(spec.initial, e0=start))
        e = simulate_programmes(model, [trial], [x], n, e0, strain_step)[0][0][key][:, -1]
        miss = np.where(np.isfinite(e), stage.e_end - e, 0.0)
        if np.all(np.abs(miss) <= VOID_RATIO_TOLERANCE):
            break
        slope = np.ones(n)
        if before is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                secant = (e - before[1]) / (start - before[0])
            slope = np.where(np.isfinite(secant) & (secant > 0.0), secant, 1.0)
        before = (start, e)
        start = start + miss / slope
    return replace(spec, initial=replace(spec.initial, e0=start))


def _rounds(specs) -> list:
    """[[(test, stage index), ...] per round] (:func:`simulate_programmes`): each round the stage signature that is
    next for the most tests (the first such in test order on a tie)."""
    position, rounds = [0] * len(specs), []
    while any(position[j] < len(spec.stages) for j, spec in enumerate(specs)):
        waiting = {}
        for j, spec in enumerate(specs):
            if position[j] < len(spec.stages):
                waiting.setdefault(stage_signature(spec.stages[position[j]]), []).append(j)
        members = max(waiting.values(), key=len)
        rounds.append([(j, position[j]) for j in members])
        for j in members:
            position[j] += 1
    return rounds


def _stack(models, n):
    """One model over (len(models) x n) points from models of the same class and parameters, each over n."""
    if len(models) == 1:
        return models[0]
    names = [k for k, v in models[0].parameters().items() if v is not None]
    return models[0].replaced({k: np.concatenate([np.broadcast_to(np.asarray(m.parameters()[k], dtype=float), (n,))
                                                   for m in models]) for k in names})


def _merge(plans, rows, size):
    """(increments (K, size, 6), dt (K, size), active (K, size) or None, record (K,), column of each plan's records)
    of the stage plans of a round, plan j over the points ``rows[j]`` (a slice), aligned by step index
    (:func:`simulate_programmes`)."""
    tables = [plan.steps() for plan in plans]
    length = max(len(dt) for _, dt in tables)
    inc, dt = np.zeros((length, size, 6)), np.zeros((length, size))
    active = np.zeros(dt.shape, dtype=bool)
    record = np.zeros(length, dtype=bool)
    record[-1] = True  # the stage's end state is carried on
    for plan, (inc_j, dt_j), rows_j in zip(plans, tables, rows):
        inc[:len(dt_j), rows_j], dt[:len(dt_j), rows_j] = inc_j, dt_j
        active[:len(dt_j), rows_j] = True if plan.taken is None else plan.taken
        record[plan.record_index] = True
    slot = np.cumsum(record)  # history column of each recorded step (column 0: the stage start)
    return inc, dt, (None if active.all() else active), record, [slot[plan.record_index] for plan in plans]


def _adaptive(model, part, plans, rows, strain_step):
    """(history, column of each plan's records) of one round by ``labtests.adaptive_control``: the plans' paths
    side by side, plan j over the points ``rows[j]``, every strain increment at most ``strain_step``; a plan with
    fewer records repeats its end."""
    size = part["stress"].shape[0]
    count = max(len(plan.record_index) for plan in plans)
    records = np.zeros((count, size))
    segments = [np.zeros((len(plans[0].segments[0]), size)) for _ in range(4)]
    for plan, rows_j in zip(plans, rows):
        tau = plan.records()
        records[:, rows_j] = plan.knots[-1]
        records[:len(tau), rows_j] = tau
        for whole, piece in zip(segments, plan.segments):
            whole[:, rows_j] = piece
    target = labtests.LinearPath.stacked([plan.target() for plan in plans])  # the rows are consecutive slices
    hist = labtests.adaptive_control(model, part["stress"], part["state"], plans[0].control, target, segments,
                                     records, undrained=plans[0].undrained, active=~part["failed"],
                                     strain_step=strain_step)
    return hist, [1 + np.arange(len(plan.record_index)) for plan in plans]


def _live_start(part, rows):
    """The stage start {stress, strain, u} of the points ``rows`` of ``part``, a failed point's replaced by the first
    live point's: a failed point takes no further step, and what the points of a stage share (its intervals aligned
    on the point needing the most steps, a load ramp's grid) must come from the live points alone, so that a
    parameter set gets the same bits in any batch."""
    start = {k: part[k][rows] for k in ("stress", "strain", "u")}
    failed = part["failed"][rows]
    live = np.flatnonzero(~failed)
    if failed.any() and live.size:
        start = {k: np.where(failed.reshape((-1,) + (1,) * (v.ndim - 1)), v[live[0]], v) for k, v in start.items()}
    return start


def _take(carried, index):
    """The carried specimen's rows ``index`` (the model state included)."""
    return {k: (_take(v, index) if isinstance(v, dict) else v[index]) for k, v in carried.items()}


def _put(carried, index, part):
    """The carried specimen with its rows ``index`` replaced by ``part``."""
    out = {}
    for k, v in carried.items():
        if isinstance(v, dict):
            out[k] = _put(v, index, part[k])
        else:
            out[k] = v.copy()
            out[k][index] = part[k]
    return out


def _simulate_group(prepared, abscissae, n, strain_step=None):
    """simulate_programmes of tests of one group: prepared [(spec, specimen model, start void ratio)]."""
    specs = [spec for spec, _, _ in prepared]
    size = n * len(specs)
    model = _stack([specimen for _, specimen, _ in prepared], n)
    start_e = np.concatenate([np.broadcast_to(np.asarray(e, dtype=float), (n,)) for _, _, e in prepared])
    stress0 = np.concatenate([_initial_stress(spec.initial, n) for spec in specs])
    state, why = _start_state(model, stress0, start_e, size)
    by_stage = [_keys_by_stage(spec, x) for spec, x in zip(specs, abscissae)]
    outs = [{k: np.full((n, len(np.atleast_1d(x[k]))), np.nan) for k in x} for x in abscissae]
    if state is None:
        return [(out, np.ones(n, dtype=bool), list(why[j * n:(j + 1) * n])) for j, out in enumerate(outs)]
    step = strain_step or model.max_strain_step or FALLBACK_STRAIN_STEP
    timed = getattr(model, "rate_dependent", True)
    carried = {"stress": stress0, "state": state, "strain": np.zeros((size, 6)), "u": np.zeros(size),
               "t": np.zeros(size), "failed": why != "", "why": why}
    u0 = np.array([spec.initial.u0 for spec in specs])
    for members in _rounds(specs):
        tests = [j for j, _ in members]
        index = np.concatenate([np.arange(j * n, (j + 1) * n) for j in tests])
        whole = len(tests) == len(specs)  # the round's points: every test's, or the round's tests' only
        part = carried if whole else _take(carried, index)
        round_model = model if whole else _stack([prepared[j][1] for j in tests], n)
        rows = [slice(r * n, (r + 1) * n) for r in range(len(tests))]
        plans, wanted = [], []
        for (j, i), rows_j in zip(members, rows):
            stage = specs[j].stages[i]
            keys = by_stage[j][stage.name]
            xs = [np.atleast_1d(np.asarray(abscissae[j][k], dtype=float)) for k in keys]
            x_all = np.unique(np.concatenate(xs)) if xs else np.zeros(0)
            plans.append(StageSteps(specs[j].apparatus, stage, _live_start(part, rows_j), x_all, step, timed))
            wanted.append((keys, xs, x_all))
        plan = plans[0]  # control and drainage are the round's (stage_signature)
        u_start = part["u"] if plan.undrained else np.zeros(len(index))
        if plan.adaptive:
            hist, columns = _adaptive(round_model, part, plans, rows, step)
        else:
            inc, dt, active, record, columns = _merge(plans, rows, len(index))
            if part["failed"].any():  # a failed particle takes no further step
                active = (np.ones(dt.shape, dtype=bool) if active is None else active) & ~part["failed"]
            hist = labtests.mixed_control(round_model, part["stress"], part["state"], plan.control, inc, dt,
                                          undrained=plan.undrained, record=record, on_failure="nan", active=active,
                                          predictor="previous" if timed else "tangent")
        if any(keys for keys, _, _ in wanted):
            values = _quantities(hist, part, u_start, np.repeat(u0[tests], n)[:, None])
            for j, rows_j, (keys, xs, x_all), cols in zip(tests, rows, wanted, columns):
                for key, x in zip(keys, xs):
                    quantity = ALIASES.get(split_key(key)[0], split_key(key)[0])
                    outs[j][key] = values[quantity][rows_j][:, cols[np.searchsorted(x_all, x)]]
        part = _advance(part, hist, u_start, plan.stage)
        for p, rows_j in zip(plans, rows):
            outside = np.zeros(len(index), dtype=bool)
            outside[rows_j] = p.outside
            part = _fail(part, outside, f"stage {p.stage.name}: a record lies outside the stage")
        if plan.to_sigma_v is not None:
            part = _to_sigma_v(round_model, part, np.repeat([p.rate for p in plans], n),
                               np.repeat([p.to_sigma_v for p in plans], n), step, plan.stage)
        carried = part if whole else _put(carried, index, part)
    results = []
    for j, out in enumerate(outs):
        finite = [np.all(np.isfinite(v), axis=1) for v in out.values()] or [np.ones(n, dtype=bool)]
        rows = slice(j * n, (j + 1) * n)
        failed = carried["failed"][rows] | ~np.all(finite, axis=0)
        why = np.where(carried["failed"][rows], carried["why"][rows], "non-finite values in a recorded curve")
        for key in out:
            out[key][failed] = np.nan
        results.append((out, failed, [str(w) if f else "" for w, f in zip(why, failed)]))
    return results
