"""Side-by-side check against OpenGeoSys (a peer, never a dependency): ``python -m fem.ogs_compare [--ogs PATH]``.

Case (docs/reference.md section 6): linear elastic coupled cavity expansion, E = 5 MPa, nu = 0.3, k = 3.3e-9 m/s, outer
boundary fixed and drained at R = 50 a0, cavity impermeable, 10 % cavity strain in 60 s (100 equal steps, backward
Euler in both codes); reference 438.83 kPa cavity pressure rise and 54.22 kPa wall excess pore pressure. The same
mesh (100 x 2 cells, graded toward the cavity and toward the drained boundary) is written for OpenGeoSys with meshio
(bulk mesh + boundary meshes with ``bulk_node_ids``, all ``axially_symmetric``), with a HYDRO_MECHANICS project file
in SI units (Pa, intrinsic permeability k mu/(rho_w g), incompressible constituents, Biot coefficient 1). Variants:
equal order (bilinear u and p, like ours) and Taylor-Hood (biquadratic u on 9-node quadrilaterals, bilinear p).

Prints JSON lines: per code and variant, the cavity pressure rise (from the reaction forces on the wall) and the wall
excess pore pressure at 10 %, their errors against the reference, and the wall time (OpenGeoSys: the whole ``ogs``
process, including its start and file output; ours: one solve, the Solver built once, plus the build time). The
``ogs`` executable is looked up with --ogs, $OGS_BIN, then PATH (``pip install ogs`` in a throwaway venv provides
it); without it the script prints one ``skipped`` line and exits 0.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import tempfile
import time

import numpy as np

import constitutive as C

from . import Solver, pressuremeter
from .mesh import Mesh, two_sided_radii
from .problem import edges_of_set

A0, E, NU, K = 0.0415, 5000.0, 0.3, 3.3e-9
R = 50 * A0
EPS, DURATION, STEPS = 0.10, 60.0, 100
REFERENCE = {"pressure_rise_kPa": 438.83, "excess_pore_pressure_kPa": 54.22}
VISCOSITY, RHO_W = 1.0e-3, 1000.0                      # Pa s, kg/m3 (only their ratio with k matters)


def case_mesh():
    return Mesh.cavity_strip(radii=two_sided_radii(A0, R, 50, 50, 1e-3), n_vertical=2)


def run_ours(mesh):
    t0 = time.perf_counter()
    solver = Solver(pressuremeter(C.LinearElastic(E, NU), mesh=mesh, sigma_v0=0.0, K0=1.0, u0=0.0, permeability=K,
                                  strain_rate=EPS / DURATION, n_increments=STEPS, outer="fixed", save_fields="none"))
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    r = solver.solve()
    return {"pressure_rise_kPa": float(r.cavity_pressure[-1]),
            "excess_pore_pressure_kPa": float(r.cavity_excess_pore_pressure[-1]),
            "wall_s": time.perf_counter() - t0, "build_s": build, "n_cells": mesh.n_cells, "n_nodes": mesh.n_nodes,
            "newton_iterations": solver.stats["residuals"] - STEPS}


# ---------------------------------------------------------------------------------------------- OpenGeoSys input
def _quadratic(mesh):
    """9-node quadrilaterals (VTK order: 4 corners, 4 mid-edge nodes, centre) on the same geometry: the corner nodes
    keep their numbers, mid-edge nodes are shared between neighbours. Returns (points, cells (n, 9), node map of
    boundary sets)."""
    pts = [p for p in mesh.nodes]
    edge_id = {}
    cells9 = []
    for c in mesh.cells:
        mids = []
        for a, b in zip(c, np.roll(c, -1)):
            key = (min(a, b), max(a, b))
            if key not in edge_id:
                edge_id[key] = len(pts)
                pts.append(0.5 * (mesh.nodes[a] + mesh.nodes[b]))
            mids.append(edge_id[key])
        centre = len(pts)
        pts.append(mesh.nodes[c].mean(axis=0))
        cells9.append(list(c) + mids + [centre])
    return np.array(pts), np.array(cells9), edge_id


def write_ogs_inputs(mesh, folder, taylor_hood):
    """Bulk and boundary meshes (meshio VTU) and the project file; returns the project path."""
    import meshio

    if taylor_hood:
        pts, cells, edge_id = _quadratic(mesh)
        bulk = meshio.Mesh(np.column_stack([pts, np.zeros(len(pts))]), [("quad9", cells)])
    else:
        pts, edge_id = mesh.nodes, {}
        bulk = meshio.Mesh(np.column_stack([pts, np.zeros(len(pts))]), [("quad", mesh.cells)])
    bulk.cell_data["MaterialIDs"] = [np.zeros(len(mesh.cells), np.int32)]
    bulk.write(os.path.join(folder, "bulk.vtu"), binary=False)
    for name in ("cavity", "outer", "top", "bottom"):
        e = edges_of_set(mesh, name)
        ids = np.unique(np.concatenate([e.ravel()] + ([np.array([edge_id[(min(a, b), max(a, b))] for a, b in e])]
                                                      if taylor_hood else [])))
        local = {g: i for i, g in enumerate(ids)}
        if taylor_hood:
            cells = [("line3", np.array([[local[a], local[b], local[edge_id[(min(a, b), max(a, b))]]] for a, b in e]))]
        else:
            cells = [("line", np.array([[local[a], local[b]] for a, b in e]))]
        m = meshio.Mesh(np.column_stack([pts[ids], np.zeros(len(ids))]), cells,
                        point_data={"bulk_node_ids": ids.astype(np.uint64)})
        m.write(os.path.join(folder, f"{name}.vtu"), binary=False)
    path = os.path.join(folder, "cavity.prj")
    with open(path, "w") as f:
        f.write(_project(order=2 if taylor_hood else 1))
    return path


def _project(order):
    k_intrinsic = K * VISCOSITY / (RHO_W * 9.81)       # m2, from the hydraulic conductivity k (m/s)
    rate = A0 * EPS / DURATION                         # m/s, cavity wall velocity
    meshes = "".join(f'<mesh axially_symmetric="true">{n}.vtu</mesh>' for n in ("bulk", "cavity", "outer", "top",
                                                                                "bottom"))

    def dirichlet(mesh, component, parameter):
        return (f"<boundary_condition><mesh>{mesh}</mesh><type>Dirichlet</type><component>{component}</component>"
                f"<parameter>{parameter}</parameter></boundary_condition>")

    def prop(name, value):
        return f"<property><name>{name}</name><type>Constant</type><value>{value}</value></property>"

    return f"""<?xml version="1.0" encoding="ISO-8859-1"?>
<OpenGeoSysProject>
 <meshes>{meshes}</meshes>
 <processes><process>
  <name>HM</name><type>HYDRO_MECHANICS</type><integration_order>{order + 1}</integration_order>
  <constitutive_relation><type>LinearElasticIsotropic</type><youngs_modulus>E</youngs_modulus>
   <poissons_ratio>nu</poissons_ratio></constitutive_relation>
  <process_variables><displacement>displacement</displacement><pressure>pressure</pressure></process_variables>
  <secondary_variables><secondary_variable internal_name="sigma" output_name="sigma"/></secondary_variables>
  <specific_body_force>0 0</specific_body_force>
 </process></processes>
 <media><medium id="0">
  <phases>
   <phase><type>AqueousLiquid</type><properties>{prop("viscosity", VISCOSITY)}{prop("density", RHO_W)}</properties>
   </phase>
   <phase><type>Solid</type><properties>{prop("density", 2000.0)}</properties></phase>
  </phases>
  <properties>{prop("porosity", 0.5)}{prop("biot_coefficient", 1.0)}{prop("reference_temperature", 293.15)}
   {prop("permeability", k_intrinsic)}</properties>
 </medium></media>
 <time_loop>
  <processes><process ref="HM">
   <nonlinear_solver>newton</nonlinear_solver>
   <convergence_criterion><type>PerComponentDeltaX</type><norm_type>NORM2</norm_type><!-- p (Pa), u_r, u_z (m) -->
    <abstols>1e-4 1e-14 1e-14</abstols></convergence_criterion>
   <time_discretization><type>BackwardEuler</type></time_discretization>
   <time_stepping><type>FixedTimeStepping</type><t_initial>0</t_initial><t_end>{DURATION}</t_end>
    <timesteps><pair><repeat>{STEPS}</repeat><delta_t>{DURATION / STEPS}</delta_t></pair></timesteps>
   </time_stepping>
  </process></processes>
  <output><type>VTK</type><prefix>cavity</prefix>
   <timesteps><pair><repeat>1</repeat><each_steps>{STEPS}</each_steps></pair></timesteps>
   <variables><variable>displacement</variable><variable>pressure</variable><variable>NodalForces</variable>
   </variables></output>
 </time_loop>
 <parameters>
  <parameter><name>E</name><type>Constant</type><value>{E * 1e3}</value></parameter>
  <parameter><name>nu</name><type>Constant</type><value>{NU}</value></parameter>
  <parameter><name>zero</name><type>Constant</type><value>0</value></parameter>
  <parameter><name>zero2</name><type>Constant</type><values>0 0</values></parameter>
  <parameter><name>wall</name><type>Function</type><expression>{rate!r}*t</expression></parameter>
 </parameters>
 <process_variables>
  <process_variable><name>displacement</name><components>2</components><order>{order}</order>
   <initial_condition>zero2</initial_condition><boundary_conditions>
   {dirichlet("cavity", 0, "wall")}{dirichlet("outer", 0, "zero")}{dirichlet("top", 1, "zero")}
   {dirichlet("bottom", 1, "zero")}</boundary_conditions></process_variable>
  <process_variable><name>pressure</name><components>1</components><order>1</order>
   <initial_condition>zero</initial_condition><boundary_conditions>{dirichlet("outer", 0, "zero")}
   </boundary_conditions></process_variable>
 </process_variables>
 <nonlinear_solvers><nonlinear_solver><name>newton</name><type>Newton</type><max_iter>20</max_iter>
  <linear_solver>direct</linear_solver></nonlinear_solver></nonlinear_solvers>
 <linear_solvers><linear_solver><name>direct</name><eigen><solver_type>SparseLU</solver_type><scaling>true</scaling>
  </eigen></linear_solver></linear_solvers>
</OpenGeoSysProject>
"""


def run_ogs(ogs, mesh, taylor_hood):
    import meshio

    with tempfile.TemporaryDirectory(prefix="ogs_cavity_") as folder:
        prj = write_ogs_inputs(mesh, folder, taylor_hood)
        t0 = time.perf_counter()
        proc = subprocess.run([ogs, "-o", folder, prj], cwd=folder, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            raise RuntimeError(f"ogs failed (exit {proc.returncode}): {(proc.stdout + proc.stderr)[-2000:]}")
        last = sorted((f for f in os.listdir(folder) if f.startswith("cavity_ts_") and f.endswith(".vtu")),
                      key=lambda f: int(f.split("_ts_")[1].split("_")[0]))[-1]
        out = meshio.read(os.path.join(folder, last))
    wall_nodes = mesh.node_sets["cavity"]                  # corner nodes keep their numbers in both variants
    on_wall = np.isclose(out.points[:, 0], A0, rtol=0.0, atol=1e-9 * R)
    H = np.ptp(mesh.nodes[:, 1])
    # NodalForces: the assembled internal forces int B^T sigma_total dV (N, over the full circumference, outward
    # positive on the wall nodes), i.e. the reaction holding the wall: total radial stress x 2 pi a0 H
    pressure = out.point_data["NodalForces"][on_wall, 0].sum() / (2 * np.pi * A0 * H) / 1e3
    return {"pressure_rise_kPa": float(pressure),
            "excess_pore_pressure_kPa": float(out.point_data["pressure"][wall_nodes].mean() / 1e3),
            "wall_s": wall, "n_cells": mesh.n_cells, "n_nodes": len(out.points),
            "newton_iterations": proc.stdout.count("] Iteration #")}


def find_ogs(given=None):
    for candidate in (given, os.environ.get("OGS_BIN"), shutil.which("ogs")):
        if candidate and os.path.isfile(candidate) and os.access(candidate, os.X_OK):
            return candidate
    return None


def _line(code, variant, res):
    out = {"code": code, "variant": variant}
    out.update({k: (round(v, 4) if isinstance(v, float) else v) for k, v in res.items()})
    for key, ref in REFERENCE.items():
        out[key.replace("_kPa", "_error_pct")] = round(100.0 * (res[key] - ref) / ref, 3)
    print(json.dumps(out), flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ogs", help="path of the ogs executable (default: $OGS_BIN, then PATH)")
    ap.add_argument("--repeat", type=int, default=3, help="solves per code and variant (best wall time reported)")
    args = ap.parse_args(argv)
    mesh = case_mesh()
    best = min((run_ours(mesh) for _ in range(args.repeat)), key=lambda r: r["wall_s"])
    _line("geoinfer", "equal_order_uniform_strain", best)
    ogs = find_ogs(args.ogs)
    if ogs is None:
        print(json.dumps({"code": "OpenGeoSys", "skipped": "no ogs executable (pip install ogs in a separate venv, "
                          "then pass --ogs or set OGS_BIN)"}), flush=True)
        return
    for taylor_hood in (False, True):
        variant = "taylor_hood" if taylor_hood else "equal_order"
        try:
            res = min((run_ogs(ogs, mesh, taylor_hood) for _ in range(args.repeat)), key=lambda r: r["wall_s"])
        except (RuntimeError, KeyError, IndexError) as err:
            print(json.dumps({"code": "OpenGeoSys", "variant": variant, "failed": str(err)}), flush=True)
            continue
        _line("OpenGeoSys", variant, res)


if __name__ == "__main__":
    main()
