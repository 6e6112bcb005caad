"""Terzaghi 1D consolidation on a column, pressure stabilization (checkerboard), bad input (REFERENCE 6-7)."""
import numpy as np
import pytest

import constitutive as C
import fem
from fem import oracles

E, NU, K = 1000.0, 0.3, 1e-7
E_OED = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
CV = K * E_OED / fem.GAMMA_W          # c_v = k E_oed / gamma_w (m2/s)
H = 1.0


def column_problem(stabilization, phases, n=10):
    mesh = fem.Mesh.column(height=H, n_vertical=n, r_inner=1.0, width=0.1)
    return fem.Problem(mesh, C.LinearElastic(E, NU), permeability=K,
                       dirichlet=[fem.Dirichlet("inner", "ur"), fem.Dirichlet("outer", "ur"),
                                  fem.Dirichlet("bottom", "uz"), fem.Dirichlet("top", "p")],
                       pressures=[fem.BoundaryPressure("top", 100.0)], history=phases,
                       stabilization=stabilization, save_fields="all")


def profile(result, snap):
    nodes = result.mesh.nodes
    col = np.isclose(nodes[:, 0], 1.0)
    order = np.argsort(-nodes[col, 1])
    return nodes[col, 1][order], snap.excess_pore_pressure[col][order], snap.displacement[col, 1][order]


def test_checkerboard_removed_by_pressure_projection():
    """One tiny undrained step (dt << h^2/(6c)) of 100 kPa: exact 100 kPa below the drained top.
    REFERENCE 7 observed 0/193/13/181/25/170 without and 0/113/98/100/100/100 with the projection."""
    tiny = [fem.Phase(1e-3, 1.0, 1)]
    _, plain, _ = profile(*(lambda r: (r, r.snapshots[-1]))(fem.solve(column_problem(False, tiny))))
    _, stab, _ = profile(*(lambda r: (r, r.snapshots[-1]))(fem.solve(column_problem(True, tiny))))
    assert np.max(np.abs(plain[1:] - 100.0)) > 50.0                  # the checkerboard (measured 0/200/0/200...)
    assert np.max(np.abs(stab[3:] - 100.0)) < 1.0                    # measured 0/113.4/98.2/100.2/100/...
    assert stab[1] == pytest.approx(113.4, abs=1.0)


@pytest.mark.parametrize("stabilization", [False, True])
def test_terzaghi(stabilization):
    """Pore pressure profiles and average degree of consolidation from the settlement against Terzaghi's series;
    identical late-time results with and without the projection."""
    t_end = 1.0 * H**2 / CV
    phases = [fem.Phase(1e-3, 1.0, 1), fem.Phase(t_end, 1.0, 120, growth=1.04)]
    r = fem.solve(column_problem(stabilization, phases, n=20))
    s_final = 100.0 * H / E_OED
    for snap in r.snapshots[30::30]:
        Tv = CV * (snap.time - 1e-3) / H**2
        z, p, uz = profile(r, snap)
        exact = oracles.terzaghi_pressure(H - z, Tv, 100.0)
        assert np.max(np.abs(p - exact)) < 1.0, (Tv, np.max(np.abs(p - exact)))
        U = -uz[0] / s_final
        # the instantaneous (undrained) settlement is zero in 1D, so U is the consolidation settlement ratio
        assert U == pytest.approx(oracles.terzaghi_degree(Tv)[0], abs=0.01)


def test_bad_input_errors():
    mesh = fem.Mesh.column()
    mat = C.LinearElastic(E, NU)
    base = dict(dirichlet=[fem.Dirichlet("bottom", "uz")], history=[fem.Phase(1.0, 1.0, 1)])
    with pytest.raises(fem.ProblemError, match="permeability"):
        fem.Problem(mesh, mat, permeability=0.0, **base)
    with pytest.raises(fem.ProblemError, match="permeability"):
        fem.Problem(mesh, mat, permeability=-1e-9, **base)
    with pytest.raises(fem.ProblemError, match="duration"):
        fem.Phase(0.0, 1.0, 1)
    with pytest.raises(fem.ProblemError, match="names no nodes"):
        fem.Problem(fem.Mesh(mesh.nodes, mesh.cells, {"empty": []}), mat,
                    dirichlet=[fem.Dirichlet("empty", "ur")], history=base["history"])
    with pytest.raises(fem.ProblemError, match="unknown node set"):
        fem.Problem(mesh, mat, dirichlet=[fem.Dirichlet("nowhere", "ur")], history=base["history"])
    with pytest.raises(fem.ProblemError, match="dof"):
        fem.Dirichlet("top", "ux")
    with pytest.raises(fem.ProblemError, match="MaterialModel"):
        fem.Problem(mesh, object(), **base)
    with pytest.raises(C.ParameterError, match="nu"):
        C.LinearElastic(E, 0.7)
    nodes = mesh.nodes.copy()
    with pytest.raises(fem.MeshError, match="inverted"):
        fem.Mesh(nodes, mesh.cells[:, ::-1])                       # clockwise = inverted
    nodes[[1, 12], 1] = 0.0                                       # first cell flattened to zero height
    with pytest.raises(fem.MeshError, match="degenerate"):
        fem.Mesh(nodes, mesh.cells)
    with pytest.raises(fem.MeshError, match="negative radius"):
        fem.Mesh(mesh.nodes - [5.0, 0.0], mesh.cells)
