"""The material-point interface shared by every constitutive model (the UMAT equivalent).

Conventions (docs/reference.md, "Conventions used everywhere"):
- soil-mechanics signs: compression positive, for stresses and strains;
- stresses are effective stresses in kPa;
- Voigt order (11, 22, 33, 12, 23, 31) with engineering shear strains (gamma_12 = 2 eps_12);
- every array carries a leading axis over material points (Gauss points of a mesh, or particles of a batched
  laboratory-test simulation). Parameters may be scalars or arrays of shape (n,) so that they differ per point.

A model is a frozen, validated parameter record with two methods::

    state = model.initial_state(stress0, void_ratio0)          # dict of arrays over n points
    stress, state, tangent = model.update(stress, state, dstrain, dt, tangent=True)

``update`` never modifies its inputs. ``tangent`` is (n, 6, 6), d(stress)/d(strain) for the increment; each model
states in ``tangent_kind`` whether it is the consistent (algorithmic) tangent, the continuum tangent or the elastic
one; ``rate_dependent`` says whether the result depends on the time increment dt. With ``tangent=False`` the
caller says it will not use the tangent: a model whose tangent costs extra work may then return None in its place
(ANICREEP does; the others return it anyway). A point whose local integration fails raises
:class:`IntegrationError` naming the point.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["ParameterError", "IntegrationError", "MaterialModel", "CompiledSteps", "ParameterRange", "as_points",
           "check_parameter", "point_rows", "iterating_rows", "updated_rows", "collapsed_void_ratio"]


class ParameterError(ValueError):
    """A model parameter outside its physical range; the message names the parameter and the value."""


class IntegrationError(RuntimeError):
    """Local (stress-point) integration failed at material point ``point`` for ``reason``."""

    def __init__(self, point, reason: str):
        self.point = point
        self.reason = reason
        super().__init__(f"stress-point integration failed at point {point}: {reason}")


def collapsed_void_ratio(e_new, e, dstrain) -> str:
    """The reason of an update that would leave the void ratio at ``e_new`` <= 0 (from ``e``) under the strain
    increment ``dstrain`` (6,): a compression beyond the solids, which no model's state can follow."""
    return (f"void ratio {e_new:.3g} <= 0 after the strain increment {dstrain} (from e = {e:.4g}): compressed "
            f"beyond the solids")


def check_parameter(name: str, value, *, lower=None, upper=None, lower_open=True, upper_open=True, model=""):
    """Return ``value`` as a float array after checking ``lower < value < upper`` (open or closed bounds).

    Raises ParameterError naming the model, the parameter and the first offending value.
    """
    arr = np.asarray(value, dtype=float)
    where = f"{model}: " if model else ""
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr)].ravel()[0]
        raise ParameterError(f"{where}parameter {name} = {bad} is not a finite number")
    if lower is not None:
        bad = arr <= lower if lower_open else arr < lower
        if np.any(bad):
            op = ">" if lower_open else ">="
            raise ParameterError(f"{where}parameter {name} = {arr[bad].ravel()[0]:g} must be {op} {lower:g}")
    if upper is not None:
        bad = arr >= upper if upper_open else arr > upper
        if np.any(bad):
            op = "<" if upper_open else "<="
            raise ParameterError(f"{where}parameter {name} = {arr[bad].ravel()[0]:g} must be {op} {upper:g}")
    return arr


@dataclass(frozen=True)
class ParameterRange:
    """The physical range of one model parameter and the range it takes in usual soils.

    ``lower < value < upper`` (``<=`` where ``lower_open``/``upper_open`` is False; None: unbounded) is what the
    model accepts (checked on construction, :meth:`check`); ``typical`` (lo, hi) is a finite range of common soils in
    the same unit (examples, starting values, tests; not enforced); ``unit`` is "-" for dimensionless parameters.
    """

    lower: float | None
    upper: float | None
    typical: tuple
    unit: str = "-"
    lower_open: bool = True
    upper_open: bool = True

    def check(self, name: str, value, model: str = ""):
        """``value`` as a float array, or ParameterError naming the model, the parameter and the offending value."""
        return check_parameter(name, value, lower=self.lower, upper=self.upper, lower_open=self.lower_open,
                               upper_open=self.upper_open, model=model)

    @property
    def middle(self) -> float:
        """The middle of the typical range."""
        return 0.5 * (self.typical[0] + self.typical[1])


def as_points(stress_or_strain, name="array") -> np.ndarray:
    """Return a float (n, 6) array; a single 6-vector becomes (1, 6)."""
    arr = np.asarray(stress_or_strain, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise ValueError(f"{name} must have shape (n, 6) in Voigt order (11, 22, 33, 12, 23, 31), got {arr.shape}")
    return arr


def point_rows(value, points):
    """A parameter (scalar or (n,)) at the points ``points`` (None: all of them; a scalar stays one)."""
    return value if points is None or np.ndim(value) == 0 else np.asarray(value)[points]


#: a Newton iteration updates only the points still iterating when they are at most this fraction of all (below it
#: the subset's gather and scatter cost less than the updates of the points done)
SUBSET_FRACTION = 0.75


def iterating_rows(model, iterating):
    """The rows (k,) of the points still ``iterating`` (bool (n,)) for :func:`updated_rows`, or None where the model
    updates every point (no ``point_subsets``, or more than SUBSET_FRACTION of the points still iterating)."""
    if not getattr(model, "point_subsets", False):
        return None
    rows = np.flatnonzero(iterating)
    return None if rows.size > SUBSET_FRACTION * iterating.size else rows


def updated_rows(model, rows, points, stress, state, dstrain, dt, previous):
    """The update of the rows ``rows`` of the arrays given (``stress``, ``state``, ``dstrain``, ``dt`` over n points),
    which are the points ``points`` of the model's parameter arrays (``MaterialModel.point_subsets``), written into
    copies of ``previous`` (stress, state, tangent of the n points). An IntegrationError names the row."""
    try:
        s_rows, st_rows, C_rows = model.update(stress[rows], {k: v[rows] for k, v in state.items()}, dstrain[rows],
                                               point_rows(dt, rows), points=points)
    except IntegrationError as err:
        raise IntegrationError(int(rows[err.point]), err.reason) from None
    s_new, st_new, C = previous
    s_new, C = s_new.copy(), C.copy()
    s_new[rows], C[rows] = s_rows, C_rows
    merged = {}
    for key, value in st_rows.items():  # the keys of the model's update
        merged[key] = np.array(st_new[key], dtype=value.dtype)
        merged[key][rows] = value
    return s_new, merged, C


@dataclass(frozen=True)
class CompiledSteps:
    """A model's compiled step loops (every step of a point in one compiled call): ``drive(parameters, settings,
    stress0, state0, steps, stop, newton, history, ending)`` (``mixed_control``) as
    ``constitutive._step_loops.drive_points`` and ``adapt(...)`` (``adaptive_control``) as its
    ``adapt_points``, with the model's update of one point; ``parameters`` (n, P) and ``settings`` its arrays;
    ``state_columns`` ((name, width), ...) the state's keys in the order of its flat (n, S) array; ``info_size``
    the length of a failure's ``info``; ``failure(code, info, dstrain)`` the reason of a failure code (the text of
    the model's IntegrationError).
    """
    drive: Callable
    adapt: Callable
    parameters: np.ndarray
    settings: np.ndarray
    state_columns: tuple
    info_size: int
    failure: Callable

    def pack(self, state, n):
        """The state dict as the flat (n, S) array of ``state_columns``."""
        columns = []
        for key, width in self.state_columns:
            value = np.asarray(state[key], dtype=float)
            columns.append(np.broadcast_to(value.reshape(-1, width) if value.ndim else value, (n, width)))
        return np.ascontiguousarray(np.hstack(columns))

    def unpack(self, flat):
        """The flat (n, S) state as the model's dict ((n,) for a width of 1, (n, width) otherwise)."""
        out, start = {}, 0
        for key, width in self.state_columns:
            out[key] = flat[:, start] if width == 1 else flat[:, start:start + width]
            start += width
        return out


class MaterialModel:
    """Base class of material-point models. Subclasses set ``name`` and ``tangent_kind`` and implement
    ``initial_state`` and ``update``. Parameters are stored as attributes (float arrays broadcastable to (n,)).

    The class attributes below describe a model for the registry (:mod:`constitutive.registry`) and for the study
    readers: parameter names and physical ranges, which parameters are required, the physics switches (constructor
    keywords, True/False) and the parameters each switch needs when on.
    """

    name = "material"
    tangent_kind = "consistent"
    #: True when ``update`` depends on the time increment dt (viscous models); False for rate-independent models
    rate_dependent = False
    #: the parameter record (names as in docs/reference.md)
    parameter_names: tuple = ()
    #: name -> ParameterRange of every parameter the constructor checks
    parameter_ranges: dict = {}
    #: parameters without which the model cannot be built, whatever its switches
    required_parameters: tuple = ()
    #: physics switches (constructor keywords) -> default
    switches: dict = {}
    #: switch -> the parameters it needs when on (they are not parameters of the model when it is off)
    switch_parameters: dict = {}
    #: defaults of optional parameters (the constructor's)
    parameter_defaults: dict = {}
    #: groups of parameters of which exactly one / at most one is given
    exactly_one: tuple = ()
    at_most_one: tuple = ()
    #: switches of the missing-physics catalog (``physics_catalog``, present_when) that this model does not take,
    #: with the value the model has (e.g. viscous=False for a rate-independent model)
    catalog_switches: dict = {}
    #: the initial void ratio is a model parameter (``e0``), not a condition of each test
    void_ratio_parameter = False
    #: constraints between parameters that the constructor enforces, as expressions of ``inference.Prior``
    parameter_constraints: tuple = ()
    #: the constructor takes ``vertical_axis`` (the deposition axis of an anisotropic initial fabric)
    oriented = False
    #: laboratory drivers default to strain steps of at most this; None: the model's own triaxial integrator
    #: controls its substeps (one driver step per record)
    max_strain_step: float | None = 0.0025
    #: constructor options that are neither parameters nor physics switches (kept by :meth:`replaced`)
    option_names: tuple = ()
    #: ``update`` takes ``points=`` (k,): the rows given are those points of the model's parameter arrays, and the
    #: results are their rows of the update of every point, bit for bit (the points are integrated independently);
    #: the laboratory drivers then integrate only the points still iterating
    point_subsets = False

    def compiled_steps(self, n):
        """The model's compiled step loop for ``mixed_control`` over n points (:class:`CompiledSteps`), or None
        where the model has none (the driver then steps in Python, calling :meth:`update`)."""
        return None

    def _checked(self, name, value):
        """``value`` of parameter ``name`` checked against ``parameter_ranges[name]`` (ParameterError)."""
        return self.parameter_ranges[name].check(name, value, model=self.name)

    def initial_state(self, stress0, void_ratio0=None) -> dict:
        raise NotImplementedError

    def update(self, stress, state: dict, dstrain, dt: float, tangent: bool = True):
        raise NotImplementedError

    def kernel_parameters(self, n):
        """(n, ncol) C-contiguous per-point parameter rows for a compiled kernel, built once per n and cached (the
        model is immutable). The columns, in the kernel's order, come from ``_kernel_columns(n)``: a sequence of
        scalars or (n,) arrays."""
        cache = self.__dict__.setdefault("_kernel_parameter_cache", {})
        if n not in cache:
            cache[n] = np.ascontiguousarray(np.column_stack(
                [np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in self._kernel_columns(n)]))
        return cache[n]

    def kernel_rows(self, n, points=None):
        """``kernel_parameters(n)``, or with ``points`` (n,) the rows of those points of the model's parameter table
        (``point_subsets``)."""
        if points is None:
            return self.kernel_parameters(n)
        size = self.parameter_points()
        return self.kernel_parameters(n) if size == 1 else self.kernel_parameters(size)[points]

    def parameter_points(self) -> int:
        """The number of points the parameters are given for (1 when all are scalars)."""
        if "_parameter_points" not in self.__dict__:
            self._parameter_points = max([int(np.size(v)) for v in self.parameters().values() if v is not None] + [1])
        return self._parameter_points

    def _kernel_columns(self, n):
        raise NotImplementedError(f"{self.name} has no compiled kernel")

    def parameters(self) -> dict:
        """The parameter record as a dict (names as in docs/reference.md)."""
        return {k: getattr(self, k) for k in self.parameter_names}

    def replaced(self, changes: dict) -> MaterialModel:
        """The same model (class, physics switches, constructor options, ``vertical_axis``) with the parameters in
        ``changes`` replaced (scalars or (n,) arrays; a value None removes that parameter)."""
        args = {k: v for k, v in {**self.parameters(), **changes}.items() if v is not None}
        args.update({s: getattr(self, s) for s in self.switches})
        args.update({o: getattr(self, o) for o in self.option_names})
        if self.oriented:
            args["vertical_axis"] = self.vertical_axis
        return type(self)(**args)

    def __repr__(self):
        body = ", ".join(f"{k}={np.array2string(np.asarray(v), precision=4)}" for k, v in self.parameters().items())
        return f"{type(self).__name__}({body})"
