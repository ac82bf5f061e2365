"""Vertices of STL (binary or ASCII) and Wavefront OBJ mesh files, for convex-hull geoms.

Only the vertex positions matter: tumble collides with the convex hull of a mesh, so
faces, normals and materials are not read.
"""
import os
import struct

import numpy as np

MESH_FORMATS = (".stl", ".obj")


class MeshFileError(Exception):
    """A mesh file that cannot be read (the loaders turn it into a warning or ModelError)."""


def read_mesh_vertices(path):
    """Vertex positions (n, 3) in the file's units and frame. Raises MeshFileError."""
    ext = os.path.splitext(path)[1].lower()
    if ext not in MESH_FORMATS:
        raise MeshFileError(f"mesh format '{ext or path}' is not read (only STL and OBJ)")
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise MeshFileError(f"cannot read mesh file '{path}': {e.strerror or e}") from None
    verts = _stl(data, path) if ext == ".stl" else _obj(data, path)
    if len(verts) == 0:
        raise MeshFileError(f"mesh file '{path}' has no vertices")
    if not np.all(np.isfinite(verts)):
        raise MeshFileError(f"mesh file '{path}' has non-finite vertices")
    return verts


def _stl(data, path):
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * count:          # binary: the size is exact
            rec = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                                      ("a", "<u2")]), count=count, offset=84)
            return rec["v"].reshape(-1, 3).astype(float)
    text = data.decode("ascii", errors="replace")
    if not text.lstrip().startswith("solid"):
        raise MeshFileError(f"mesh file '{path}' is neither binary nor ASCII STL")
    out = []
    for line in text.splitlines():
        parts = line.split()
        if parts and parts[0] == "vertex":
            try:
                out.append([float(x) for x in parts[1:4]])
            except ValueError:
                raise MeshFileError(f"mesh file '{path}': bad vertex line '{line.strip()}'") \
                    from None
    return np.array(out, dtype=float).reshape(-1, 3)


def _obj(data, path):
    out = []
    for i, line in enumerate(data.decode("utf-8", errors="replace").splitlines(), 1):
        parts = line.split()
        if parts and parts[0] == "v":
            try:
                out.append([float(x) for x in parts[1:4]])
            except ValueError:
                raise MeshFileError(f"mesh file '{path}' line {i}: bad vertex "
                                    f"'{line.strip()}'") from None
            if len(out[-1]) != 3:
                raise MeshFileError(f"mesh file '{path}' line {i}: a vertex needs x y z")
    return np.array(out, dtype=float).reshape(-1, 3)
