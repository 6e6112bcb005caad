"""Geometry of the CAX4RP-like axisymmetric element (docs/reference.md section 7), precomputed once for all cells.

4 nodes, bilinear displacements (u_r, u_z) and bilinear pore pressure at the corners. All integrals are per radian
(the factor 2 pi cancels everywhere) and r-weighted: dV = r dr dz. Tension-positive FE strain vector
(eps_rr, eps_zz, eps_tt, gamma_rz).

- Displacements: uniform-strain ("B-bar") one-point formulation of Flanagan & Belytschko (1981):
  B_bar = (1/V) integral B dV, so the hoop row is (1/V) integral N/r dV = (1/V) integral N dA
  (docs/reference.md section 7). The 2x2 Gauss rule integrates these exactly for any straight-sided quadrilateral
  (the integrands adj(J) dN/dxi r are polynomials of degree <= 3 per direction).
- Hourglass control, stiffness type: K_hg = c_hg G_hg V (b_r.b_r + b_z.b_z) (gamma gamma^T (x) I_2) with the
  Flanagan-Belytschko vector gamma = h - (h.r) b_r - (h.z) b_z, h = (1, -1, 1, -1), b_r, b_z the averaged
  gradients (rows of B_bar); gamma is orthogonal to every linear field.
- Pore pressure: full 2x2 Gauss for the flow matrix H = integral grad N . grad N^T dV (one-point flow would leave the
  checkerboard without stiffness), the mass matrix M = integral N N^T dV and n_bar = integral N dV; the coupling
  uses the element-mean pore pressure acting on the uniform volumetric strain, Q = (B_bar^T m) n_bar^T.
"""
from __future__ import annotations

import numpy as np

__all__ = ["ElementGeometry", "gauss_jacobians"]

_G = 1.0 / np.sqrt(3.0)
XI = np.array([[-_G, -_G], [_G, -_G], [_G, _G], [-_G, _G]])            # 2x2 Gauss points (weights 1)
CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
#: N[g, a] shape function a at Gauss point g; DN[g, a, i] derivative d N_a / d xi_i
N_GP = 0.25 * (1 + XI[:, None, 0] * CORNERS[None, :, 0]) * (1 + XI[:, None, 1] * CORNERS[None, :, 1])
DN_GP = np.stack([0.25 * CORNERS[None, :, 0] * (1 + XI[:, None, 1] * CORNERS[None, :, 1]),
                  0.25 * CORNERS[None, :, 1] * (1 + XI[:, None, 0] * CORNERS[None, :, 0])], axis=-1)
HOURGLASS = np.array([1.0, -1.0, 1.0, -1.0])


def gauss_jacobians(xe):
    """Jacobian determinants (n_cells, 4) at the 2x2 Gauss points of cells with corner coordinates xe (n, 4, 2)."""
    J = np.einsum("gai,naj->ngij", DN_GP, xe)
    return J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]


class ElementGeometry:
    """Per-cell arrays for the mesh ``nodes`` (n_nodes, 2) and ``cells`` (n, 4).

    Attributes (per radian, m-based): volume (n,), B (n, 4, 8) the uniform-strain matrix with u dofs ordered
    (u_r1, u_z1, u_r2, ...), vol_row (n, 8) = m^T B, n_bar (n, 4), H (n, 4, 4) = integral grad N.grad N dV,
    M (n, 4, 4) = integral N N dV, hg (n, 8, 8) the unit hourglass matrix V (b.b) gamma gamma^T (x) I_2 (scaled by
    c_hg G_hg in the solver), centroid (n, 2) the r-weighted centroid (r, z).
    """

    def __init__(self, nodes, cells):
        xe = nodes[cells]                                                 # (n, 4, 2)
        J = np.einsum("gai,naj->ngij", DN_GP, xe)                         # (n, g, 2, 2)
        det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
        inv = np.empty_like(J)
        inv[..., 0, 0] = J[..., 1, 1] / det
        inv[..., 1, 1] = J[..., 0, 0] / det
        inv[..., 0, 1] = -J[..., 0, 1] / det
        inv[..., 1, 0] = -J[..., 1, 0] / det
        dNdx = np.einsum("ngij,gaj->ngai", inv, DN_GP)                    # (n, g, a, 2): dN_a/dr, dN_a/dz
        r_gp = np.einsum("ga,na->ng", N_GP, xe[..., 0])
        area_w = det                                                      # dA weight (Gauss weights are 1)
        w = det * r_gp                                                    # dV = r dA per radian
        V = w.sum(axis=1)
        self.volume = V
        self.centroid = np.einsum("ng,ga,nai->ni", w, N_GP, xe) / V[:, None]
        b = np.einsum("ng,ngai->nai", w, dNdx) / V[:, None, None]         # averaged gradients (n, 4, 2)
        n_over_r = np.einsum("ng,ga->na", area_w, N_GP) / V[:, None]      # (1/V) integral N/r dV
        n = len(cells)
        B = np.zeros((n, 4, 8))
        B[:, 0, 0::2] = b[..., 0]
        B[:, 1, 1::2] = b[..., 1]
        B[:, 2, 0::2] = n_over_r
        B[:, 3, 0::2] = b[..., 1]
        B[:, 3, 1::2] = b[..., 0]
        self.B = B
        self.vol_row = B[:, 0] + B[:, 1] + B[:, 2]
        self.n_bar = np.einsum("ng,ga->na", w, N_GP)
        self.H = np.einsum("ng,ngai,ngbi->nab", w, dNdx, dNdx)
        self.M = np.einsum("ng,ga,gb->nab", w, N_GP, N_GP)
        gamma = (HOURGLASS[None, :] - np.einsum("a,na->n", HOURGLASS, xe[..., 0])[:, None] * b[..., 0]
                 - np.einsum("a,na->n", HOURGLASS, xe[..., 1])[:, None] * b[..., 1])
        bb = np.einsum("nai,nai->n", b, b)
        hg = np.zeros((n, 8, 8))
        gg = V[:, None, None] * bb[:, None, None] * gamma[:, :, None] * gamma[:, None, :]
        hg[:, 0::2, 0::2] = gg
        hg[:, 1::2, 1::2] = gg
        self.hg = hg
