"""Results of a solve: the cavity curve, pore-pressure histories at chosen radii, field snapshots (VTU, pictures).

Reported in the soil convention: stresses and pressures compression positive (kPa), cavity strain = u_a/a0 with
u_a the outward wall displacement. ``cavity_pressure`` is the total radial stress on the wall (the pressuremeter
reading), ``cavity_pore_pressure`` the total pore pressure u at the wall and ``cavity_excess_pore_pressure`` u - u0.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

__all__ = ["Result", "Snapshot"]


@dataclass
class Snapshot:
    """Fields at time ``time`` (s): displacement (n_nodes, 2) (u_r, u_z) m; excess and total pore pressure
    (n_nodes,) kPa; effective stress (n_cells, 6) soil Voigt (r, z, theta, rz, 0, 0), compression positive;
    strain (n_cells, 4) FE (rr, zz, tt, rz), tension positive."""

    time: float
    displacement: np.ndarray
    excess_pore_pressure: np.ndarray
    pore_pressure: np.ndarray
    stress: np.ndarray
    strain: np.ndarray


class Result:
    """Curves (numpy arrays over recorded times, t = 0 first) and snapshots; see module docstring."""

    def __init__(self, solver, problem):
        self.mesh = problem.mesh
        self.u0 = problem.initial.u0
        self.monitor_radii = tuple(problem.monitor_radii)
        self._rows = []
        self._monitors = []
        self.snapshots = []

    def record(self, t, amplitude, x, solver):
        if solver.cavity_ur is not None:
            strain = x[solver.cavity_ur].mean() / solver.cavity_radius
            pressure = solver.cavity_pressure(x)
            pex = x[solver.cavity_p].mean()
        else:
            strain = pressure = pex = np.nan
        self._rows.append((t, amplitude, strain, pressure, pex))
        if self.monitor_radii:
            self._monitors.append(np.interp(self.monitor_radii, solver.monitor_r, x[solver.monitor_nodes]))

    def snapshot(self, snap):
        self.snapshots.append(snap)

    def finish(self):
        rows = np.array(self._rows)
        self.time, self.amplitude, self.cavity_strain, self.cavity_pressure, self.cavity_excess_pore_pressure = rows.T
        self.cavity_pore_pressure = self.cavity_excess_pore_pressure + self.u0
        mon = np.array(self._monitors).reshape(len(rows), len(self.monitor_radii))
        #: excess pore pressure histories (kPa) at the monitor radii, {radius m: array over time}
        self.monitor_excess_pore_pressure = {r: mon[:, i] for i, r in enumerate(self.monitor_radii)}
        del self._rows, self._monitors
        return self

    def curve(self):
        """The cavity curve as a dict of arrays (time s, cavity_strain, cavity_pressure kPa, pore pressures kPa)."""
        return {"time": self.time, "cavity_strain": self.cavity_strain, "cavity_pressure": self.cavity_pressure,
                "cavity_pore_pressure": self.cavity_pore_pressure,
                "cavity_excess_pore_pressure": self.cavity_excess_pore_pressure}

    # ------------------------------------------------------------------ output
    def write_vtu(self, directory, prefix="fields"):
        """One VTU per snapshot (meshio): point data displacement, pore pressure, excess pore pressure; cell data
        effective stresses sigma'_r, sigma'_z, sigma'_theta, tau_rz (kPa, compression positive). Returns paths."""
        os.makedirs(directory, exist_ok=True)
        paths = []
        for i, s in enumerate(self.snapshots):
            disp = np.column_stack([s.displacement, np.zeros(len(s.displacement))])
            cells = {"sigma_r_eff": s.stress[:, 0], "sigma_z_eff": s.stress[:, 1], "sigma_theta_eff": s.stress[:, 2],
                     "tau_rz": s.stress[:, 3]}
            path = os.path.join(directory, f"{prefix}_{i:04d}.vtu")
            self.mesh.write(path, point_data={"displacement": disp, "pore_pressure": s.pore_pressure,
                                              "excess_pore_pressure": s.excess_pore_pressure}, cell_data=cells)
            paths.append(path)
        return paths

    def radial_profiles(self, snap):
        """Radial profiles at mid-height: (r_nodes, excess pore pressure) and (r_cells, stresses (n, 6))."""
        nodes, cells = self.mesh.nodes, self.mesh.cells
        zmid = 0.5 * (nodes[:, 1].min() + nodes[:, 1].max())
        dz = np.abs(nodes[:, 1] - zmid)
        row = np.flatnonzero(dz <= dz.min() + 1e-9 * (np.ptp(nodes[:, 1]) + 1e-12))
        row = row[np.argsort(nodes[row, 0])]
        zc = nodes[cells, 1].mean(axis=1)
        dzc = np.abs(zc - zmid)
        crow = np.flatnonzero(dzc <= dzc.min() + 1e-9 * (np.ptp(nodes[:, 1]) + 1e-12))
        rc = nodes[cells[crow], 0].mean(axis=1)
        order = np.argsort(rc)
        rc, crow = rc[order], crow[order]
        _, first = np.unique(np.round(rc, 12), return_index=True)
        return (nodes[row, 0], snap.excess_pore_pressure[row]), (rc[first], snap.stress[crow[first]])

    def snapshot_title(self, snapshot=-1) -> str:
        """What a picture of a snapshot says it shows: its time (s) and the cavity strain then (%, the cavity curve
        interpolated to the snapshot's time)."""
        snap = self.snapshots[snapshot]
        strain = np.interp(snap.time, self.time, self.cavity_strain)
        return f"t = {snap.time:.4g} s, cavity strain {100 * strain:.2f} %"

    def plot(self, path, snapshot=-1, extent=10.0):
        """Off-screen pyvista picture (plan view, fields revolved about the axis) of excess pore pressure and
        sigma'_r, sigma'_theta around the cavity out to ``extent`` cavity radii, with the radius r (m) on the axes and
        :meth:`snapshot_title` above each field. Returns ``path``."""
        import pyvista as pv
        from vtkmodules.vtkCommonCore import vtkLogger, vtkObject

        pv.OFF_SCREEN = True
        # no window: VTK's "bad X server connection" and other render-window warnings are noise here
        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
        vtkObject.GlobalWarningDisplayOff()
        snap = self.snapshots[snapshot]
        (rn, pex), (rc, stress) = self.radial_profiles(snap)
        a0 = rn.min()
        rmax = extent * a0
        r = rn[rn <= rmax * 1.0001] if np.sum(rn <= rmax) > 2 else rn
        th = np.linspace(0.0, 2 * np.pi, 121)
        R, T = np.meshgrid(r, th, indexing="ij")
        grid = pv.StructuredGrid(R * np.cos(T), R * np.sin(T), np.zeros_like(R))
        fields = {"excess pore pressure (kPa)": np.interp(r, rn, pex),
                  "sigma'_r (kPa)": np.interp(r, rc, stress[:, 0]),
                  "sigma'_theta (kPa)": np.interp(r, rc, stress[:, 2])}
        plotter = pv.Plotter(off_screen=True, shape=(1, 3), window_size=(1500, 520))
        for i, (name, val) in enumerate(fields.items()):
            plotter.subplot(0, i)
            g = grid.copy()
            g.point_data[name] = np.tile(val, th.size)  # Fortran order: r fastest
            plotter.add_mesh(g, scalars=name, cmap="viridis", scalar_bar_args={
                "title": name, "vertical": True, "position_x": 0.84, "position_y": 0.15, "height": 0.6, "width": 0.05,
                "title_font_size": 11, "label_font_size": 11})
            plotter.add_text(f"{name}\n{self.snapshot_title(snapshot)}", font_size=9)
            plotter.show_bounds(xtitle="r (m)", ytitle="r (m)", show_zaxis=False, location="outer", font_size=9)
            plotter.view_xy()
            plotter.camera.zoom(0.85)
        plotter.screenshot(path)
        plotter.close()
        return path
