"""Axisymmetric coupled-consolidation (Biot u-p) finite elements for the self-boring pressuremeter.

    mesh = fem.Mesh.cavity_strip()                       # 60 x 4 CAX4RP-like elements, graded toward the cavity
    problem = fem.pressuremeter(constitutive.ModifiedCamClay(...), strain_rate=0.00167)
    result = fem.solve(problem)                          # result.cavity_strain, result.cavity_pressure, ...
    solver = fem.Solver(problem); solver.solve(material=other_model)   # build once, re-solve (calibration)

Conventions: see fem.material_point (the one sign conversion) and fem.solver (the equations).
"""
from .mesh import Mesh, MeshError
from .problem import GAMMA_W, BoundaryPressure, Dirichlet, Geostatic, Phase, Problem, ProblemError, pressuremeter
from .result import Result, Snapshot
from .solver import ConvergenceError, Solver, solve

__all__ = ["Mesh", "MeshError", "Problem", "ProblemError", "Geostatic", "Dirichlet", "BoundaryPressure", "Phase",
           "pressuremeter", "GAMMA_W", "Result", "Snapshot", "Solver", "solve", "ConvergenceError"]
