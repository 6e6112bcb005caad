"""Axisymmetric r-z meshes of 4-node quadrilaterals: structured generator graded toward the cavity, meshio I/O.

Coordinates are (r, z) in metres, r >= 0 the radius and z the vertical coordinate. Cells list their 4 corner nodes
counter-clockwise in the (r, z) plane. Named node sets (``cavity``, ``outer``, ``bottom``, ``top`` for the generator)
carry the boundary conditions.
"""
from __future__ import annotations

import numpy as np

__all__ = ["Mesh", "MeshError"]


class MeshError(ValueError):
    """A mesh that cannot be used: inverted or degenerate elements, negative radii, missing or empty node sets."""


class Mesh:
    """Nodes (n_nodes, 2) as (r, z) in m, quadrilateral cells (n_cells, 4) counter-clockwise, named node sets.

    Construction validates the geometry (:meth:`check`): every cell must have a positive Jacobian determinant at its
    four 2x2 Gauss points and no node may have r < 0.
    """

    def __init__(self, nodes, cells, node_sets=None):
        self.nodes = np.ascontiguousarray(np.asarray(nodes, dtype=float)[:, :2])
        self.cells = np.ascontiguousarray(np.asarray(cells, dtype=np.int64))
        self.node_sets = {k: np.unique(np.asarray(v, dtype=np.int64)) for k, v in (node_sets or {}).items()}
        self.check()

    @property
    def n_nodes(self):
        return self.nodes.shape[0]

    @property
    def n_cells(self):
        return self.cells.shape[0]

    def check(self):
        """Raise MeshError for cells with a non-positive Jacobian (inverted, degenerate), bad indices or r < 0."""
        if self.cells.ndim != 2 or self.cells.shape[1] != 4:
            raise MeshError(f"cells must have shape (n, 4) (4-node quadrilaterals), got {self.cells.shape}")
        if self.cells.size and (self.cells.min() < 0 or self.cells.max() >= self.n_nodes):
            raise MeshError(f"cell node indices must lie in [0, {self.n_nodes - 1}]")
        if np.any(self.nodes[:, 0] < 0.0):
            i = int(np.flatnonzero(self.nodes[:, 0] < 0)[0])
            raise MeshError(f"node {i} has negative radius r = {self.nodes[i, 0]:g} m (axisymmetric mesh)")
        from .element import gauss_jacobians  # local import: element geometry lives in one place

        detj = gauss_jacobians(self.nodes[self.cells])
        size = np.ptp(self.nodes, axis=0).prod() / max(self.n_cells, 1)
        bad = np.any(detj <= 1e-10 * size, axis=1)
        if np.any(bad):
            e = int(np.flatnonzero(bad)[0])
            raise MeshError(f"cell {e} (nodes {self.cells[e].tolist()}) is inverted or degenerate: Jacobian "
                            f"determinants {np.array2string(detj[e], precision=3)} (nodes must be counter-clockwise)")
        for name, ids in self.node_sets.items():
            if ids.size and (ids.min() < 0 or ids.max() >= self.n_nodes):
                raise MeshError(f"node set {name!r} refers to nodes outside [0, {self.n_nodes - 1}]")

    def node_set(self, name):
        """The node indices of set ``name``; MeshError if the set is unknown or names no nodes."""
        if name not in self.node_sets:
            raise MeshError(f"unknown node set {name!r}; the mesh has {sorted(self.node_sets)}")
        ids = self.node_sets[name]
        if ids.size == 0:
            raise MeshError(f"node set {name!r} names no nodes")
        return ids

    # ------------------------------------------------------------------ generator
    @classmethod
    def cavity_strip(cls, a0=0.0415, outer_radius=None, n_radial=60, n_vertical=4, height=None, ratio=None,
                     radii=None):
        """Structured strip a0 <= r <= R, 0 <= z <= height, graded geometrically toward the cavity.

        a0 (m) cavity radius; outer_radius R (m), default 3200 a0 (outer-boundary study in notes/fem.md);
        n_radial x n_vertical elements; ``ratio`` the size ratio of the last to the first radial element, default
        R/a0 (sizes proportional to r: equal spacing in ln r, natural for fields decaying as 1/r and ln r);
        height (m) default n_vertical times the first radial size, so the elements at the cavity are square. The
        cavity problem is one-dimensional in r under plane strain (top and bottom fixed vertically); the vertical
        layers only make the mesh a genuine 2D mesh. Node numbering runs fastest in z, so the coupled system has a
        narrow band. ``radii`` (increasing, from a0 to R) overrides a0, outer_radius, n_radial and ratio.
        """
        if radii is not None:
            r = np.asarray(radii, dtype=float)
            if r.ndim != 1 or r.size < 2 or np.any(np.diff(r) <= 0):
                raise MeshError("radii must be a strictly increasing 1D array of at least 2 radii")
            a0, outer_radius, n_radial, ratio = r[0], r[-1], r.size - 1, (r[-1] - r[-2]) / (r[1] - r[0])
        if a0 <= 0:
            raise MeshError(f"cavity radius a0 = {a0} m must be positive")
        R = 3200.0 * a0 if outer_radius is None else float(outer_radius)
        if R <= a0:
            raise MeshError(f"outer_radius = {R} m must exceed the cavity radius a0 = {a0} m")
        if n_radial < 1 or n_vertical < 1:
            raise MeshError(f"n_radial = {n_radial} and n_vertical = {n_vertical} must be >= 1")
        r = graded_radii(a0, R, n_radial, R / a0 if ratio is None else ratio) if radii is None else r
        H = n_vertical * (r[1] - r[0]) if height is None else float(height)
        if H <= 0:
            raise MeshError(f"height = {H} m must be positive")
        return cls._structured(r, np.linspace(0.0, H, n_vertical + 1), "cavity")

    @classmethod
    def column(cls, height=1.0, n_vertical=10, r_inner=1.0, width=0.1, n_radial=1):
        """Structured column r_inner <= r <= r_inner + width, 0 <= z <= height (Terzaghi and patch tests)."""
        r = np.linspace(r_inner, r_inner + width, n_radial + 1)
        return cls._structured(r, np.linspace(0.0, height, n_vertical + 1), "inner")

    @classmethod
    def _structured(cls, r, z, inner_name):
        """Quadrilaterals on the r x z grid, node numbering fastest in z (narrow band); sets inner/outer/bottom/top."""
        nr, nz = len(r) - 1, len(z)
        rr, zz = np.meshgrid(r, z, indexing="ij")
        nodes = np.column_stack([rr.ravel(), zz.ravel()])
        i, j = np.meshgrid(np.arange(nr), np.arange(nz - 1), indexing="ij")
        n0 = (i * nz + j).ravel()
        cells = np.column_stack([n0, n0 + nz, n0 + nz + 1, n0 + 1])
        ids = np.arange(nodes.shape[0]).reshape(nr + 1, nz)
        sets = {inner_name: ids[0], "outer": ids[-1], "bottom": ids[:, 0], "top": ids[:, -1]}
        return cls(nodes, cells, sets)

    # ------------------------------------------------------------------ meshio
    def to_meshio(self, point_data=None, cell_data=None):
        import meshio

        pts = np.column_stack([self.nodes, np.zeros(self.n_nodes)])
        pdata = {f"set_{k}": np.isin(np.arange(self.n_nodes), v).astype(np.int32) for k, v in self.node_sets.items()}
        pdata.update(point_data or {})
        cdata = {k: [np.asarray(v)] for k, v in (cell_data or {}).items()}
        return meshio.Mesh(pts, [("quad", self.cells)], point_data=pdata, cell_data=cdata)

    def write(self, path, point_data=None, cell_data=None):
        """Write with meshio (format from the extension, e.g. .vtu); node sets become 0/1 point data 'set_<name>'."""
        self.to_meshio(point_data, cell_data).write(path)

    @classmethod
    def read(cls, path):
        """Read a quadrilateral mesh with meshio (x -> r, y -> z).

        Node sets come from point data ``set_<name>`` (as written by :meth:`write`) or meshio point_sets; when none
        are present the bounding-box sets ``cavity`` (min r), ``outer`` (max r), ``bottom`` (min z), ``top`` (max z)
        are made.
        """
        import meshio

        m = meshio.read(path)
        quads = [c.data for c in m.cells if c.type == "quad"]
        if not quads:
            raise MeshError(f"{path}: no 'quad' cells (found {[c.type for c in m.cells]})")
        nodes = np.asarray(m.points, dtype=float)[:, :2]
        sets = {k[4:]: np.flatnonzero(np.asarray(v) > 0) for k, v in m.point_data.items() if k.startswith("set_")}
        sets.update({k: np.asarray(v) for k, v in (m.point_sets or {}).items()})
        if not sets:
            sets = bounding_box_sets(nodes)
        return cls(nodes, np.vstack(quads), sets)


def bounding_box_sets(nodes, rtol=1e-9):
    """Node sets on the four sides of the bounding box: cavity (min r), outer (max r), bottom (min z), top (max z)."""
    span = np.ptp(nodes, axis=0).max()
    tol = rtol * span
    r, z = nodes[:, 0], nodes[:, 1]
    return {"cavity": np.flatnonzero(r <= r.min() + tol), "outer": np.flatnonzero(r >= r.max() - tol),
            "bottom": np.flatnonzero(z <= z.min() + tol), "top": np.flatnonzero(z >= z.max() - tol)}


def two_sided_radii(a0, R, n_inner, n_outer, h_outer):
    """Radii from a0 to R: n_inner elements equally spaced in ln r up to R/2, then n_outer elements to R with sizes
    shrinking geometrically to h_outer (m) at R, to resolve the drainage boundary layer at a drained, fixed outer
    boundary (thickness ~ sqrt(c t); notes/fem.md)."""
    left = a0 * (R / 2 / a0) ** np.linspace(0.0, 1.0, n_inner + 1)
    s = np.geomspace(h_outer, 3 * (R / 2) / n_outer, n_outer)
    s *= (R / 2) / s.sum()
    right = R - np.concatenate([[0.0], np.cumsum(s)])[::-1]
    return np.concatenate([left[:-1], right])


def graded_radii(a0, R, n, ratio):
    """n + 1 radii from a0 to R with element sizes in geometric progression, last/first size = ``ratio``."""
    if ratio <= 0:
        raise MeshError(f"grading ratio = {ratio} must be positive")
    q = float(ratio) ** (1.0 / max(n - 1, 1))
    sizes = q ** np.arange(n)
    r = a0 + (R - a0) * np.concatenate([[0.0], np.cumsum(sizes)]) / sizes.sum()
    r[-1] = R
    return r
