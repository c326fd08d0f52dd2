"""Triangle meshes: the geometry type the renderer rasterises, metaballs produce, mesh files
hold and cloth, rigid worlds and fluids collide with."""

from __future__ import annotations

import numpy as np


class TriangleMesh:
    """An indexed triangle mesh with optional per-vertex normals.

    Parameters
    ----------
    vertices : (v, 3) array_like
        Vertex positions [m].
    faces : (f, 3) array_like of int
        Vertex indices of each triangle, counter-clockwise seen from outside
        (right-hand rule gives the outward normal).
    normals : (v, 3) array_like, optional
        Unit vertex normals for smooth shading. ``None`` computes area-weighted ones.
    """

    def __init__(self, vertices, faces, normals=None):
        vertices = np.ascontiguousarray(vertices, dtype=np.float32)
        faces = np.ascontiguousarray(faces, dtype=np.int32)
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise ValueError(f"vertices must have shape (v, 3), got {vertices.shape}")
        if faces.size == 0:
            faces = faces.reshape(0, 3)
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise ValueError(f"faces must have shape (f, 3), got {faces.shape}")
        if not np.isfinite(vertices).all():
            raise ValueError("vertices must be finite")
        if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
            raise ValueError(f"faces must index vertices in [0, {len(vertices) - 1}]")
        self.vertices = vertices
        self.faces = faces
        if normals is None:
            normals = self.vertex_normals()
        normals = np.ascontiguousarray(normals, dtype=np.float32)
        if normals.shape != vertices.shape:
            raise ValueError(f"normals must have shape {vertices.shape}, got {normals.shape}")
        self.normals = normals

    def __len__(self) -> int:
        return len(self.faces)

    def __repr__(self) -> str:
        return f"TriangleMesh({len(self.vertices)} vertices, {len(self.faces)} faces)"

    def _corners(self):
        v = self.vertices.astype(np.float64)
        return v[self.faces[:, 0]], v[self.faces[:, 1]], v[self.faces[:, 2]]

    def face_normals(self) -> np.ndarray:
        """Unnormalised face normals, (f, 3); their length is twice the triangle area."""
        a, b, c = self._corners()
        return np.cross(b - a, c - a)

    def vertex_normals(self) -> np.ndarray:
        """Area-weighted unit vertex normals, (v, 3) float32 (zero for unused vertices)."""
        n = np.zeros((len(self.vertices), 3))
        fn = self.face_normals()
        for corner in range(3):
            np.add.at(n, self.faces[:, corner], fn)
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return (n / np.where(length > 0, length, 1.0)).astype(np.float32)

    def area(self) -> float:
        """Total surface area [m²]."""
        return float(0.5 * np.linalg.norm(self.face_normals(), axis=1).sum())

    def volume(self) -> float:
        """Enclosed volume [m³] by the divergence theorem (meaningful for closed meshes)."""
        a, b, c = self._corners()
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)

    def transformed(self, rotation=None, translation=(0.0, 0.0, 0.0), scale=1.0) -> TriangleMesh:
        """A copy moved by ``x -> scale * R @ x + translation`` (R a (3, 3) rotation)."""
        r = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
        v = scale * self.vertices.astype(np.float64) @ r.T + np.asarray(translation)
        return TriangleMesh(v, self.faces, self.normals.astype(np.float64) @ r.T)
