"""Binary little-endian PLY writer for the cap meshes (positions, normals, triangles)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mitsuba_ref.cap_mesh import CapMesh
from safe_files.paths import write_atomic


def write_ply(path: Path, mesh: CapMesh) -> None:
    v = len(mesh.positions)
    f = len(mesh.faces)
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment rtval spherical cap\n"
        f"element vertex {v}\nproperty float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        f"element face {f}\nproperty list uchar uint vertex_indices\nend_header\n"
    ).encode("ascii")
    verts = np.concatenate([mesh.positions, mesh.normals], axis=1).astype("<f4")
    faces = np.zeros(f, dtype=[("n", "u1"), ("i", "<u4", (3,))])
    faces["n"] = 3
    faces["i"] = mesh.faces
    write_atomic(path, header + verts.tobytes() + faces.tobytes())  # never through a link
