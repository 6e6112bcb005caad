"""Field output: VTU files readable by meshio, the off-screen pyvista picture, curves at chosen radii."""
import numpy as np
import pytest

import constitutive as C
import fem

A0 = 0.0415


def small_run():
    mesh = fem.Mesh.cavity_strip(a0=A0, outer_radius=200 * A0, n_radial=20, n_vertical=2)
    pb = fem.pressuremeter(C.VonMises(s_u=20.0, nu=0.49, G=2000.0), mesh=mesh, permeability=1e-10, n_increments=10,
                           hold_time=60.0, hold_increments=5, unload_strain=0.05, unload_increments=5, outer="field",
                           monitor_radii=(A0, 2 * A0))
    return fem.solve(pb)


def test_vtu_round_trip_and_phases(tmp_path):
    import meshio

    r = small_run()
    assert len(r.snapshots) == 4                       # t = 0 and the end of the three phases
    assert r.cavity_strain[-1] == pytest.approx(0.05)
    # the monitor at the wall is the wall pore pressure
    assert np.allclose(r.monitor_excess_pore_pressure[A0], r.cavity_excess_pore_pressure, atol=1e-9)
    # holding: pore pressure dissipates at constant cavity strain
    hold = (r.time > 60.0) & (r.time <= 120.0 + 1e-9)
    assert np.all(np.diff(r.cavity_excess_pore_pressure[hold]) < 0)
    paths = r.write_vtu(tmp_path)
    m = meshio.read(paths[1])
    assert np.allclose(m.point_data["excess_pore_pressure"], r.snapshots[1].excess_pore_pressure)
    assert np.allclose(m.cell_data["sigma_r_eff"][0], r.snapshots[1].stress[:, 0])


def test_offscreen_picture(tmp_path):
    pytest.importorskip("pyvista")
    r = small_run()
    # the snapshots' titles: the programme's cavity strain at the start, after the expansion to 10 %, after the hold
    # at constant strain and after the unloading to 5 %
    assert [r.snapshot_title(i).split(", ")[1] for i in range(4)] == [
        "cavity strain 0.00 %", "cavity strain 10.00 %", "cavity strain 10.00 %", "cavity strain 5.00 %"]
    try:
        path = r.plot(str(tmp_path / "fields.png"), snapshot=1)
    except Exception as err:  # no OpenGL context on this machine: report, do not fail the physics
        pytest.skip(f"off-screen rendering unavailable: {err}")
    assert (tmp_path / "fields.png").stat().st_size > 10_000
    assert path.endswith("fields.png")
