"""Vertices of STL (binary or ASCII) and Wavefront OBJ mesh files, for convex-hull geoms.

Only the vertex positions matter: tumble collides with the convex hull of a mesh, so
faces, normals and materials are not read.
"""
import os
import struct

import numpy as np

from ..errors import ModelError
from ._files import read_file

MESH_FORMATS = (".stl", ".obj")
#: Largest mesh file tumble reads (a binary STL of about 5 million triangles).
MAX_MESH_BYTES = 256 * 2 ** 20


class MeshFileError(ModelError):
    """A mesh file that exists but cannot be read (the loaders name the geom and raise)."""


class MeshFileSkipped(MeshFileError):
    """A mesh file that is missing or in a format tumble does not read: the loaders drop
    its geom and name it in their warning."""


def read_mesh_vertices(path):
    """Vertex positions (n, 3) in the file's units and frame.

    Raises MeshFileSkipped for a missing file or a format other than STL and OBJ, and
    MeshFileError (a ModelError) for a file that cannot be read as one.
    """
    ext = os.path.splitext(path)[1].lower()
    if ext not in MESH_FORMATS:
        raise MeshFileSkipped(f"mesh format '{ext or path}' is not read (only STL and OBJ)")
    try:
        data = read_file(path, "mesh file", MAX_MESH_BYTES,
                         cap_name="tumble.io._meshfile.MAX_MESH_BYTES")
    except FileNotFoundError:
        raise MeshFileSkipped(f"mesh file '{path}' not found") from None
    except ModelError as e:
        raise MeshFileError(str(e)) from None
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
    for i, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if parts and parts[0] == "vertex":
            out.append(_xyz(parts, line, i, path))
    return np.array(out, dtype=float).reshape(-1, 3)


def _xyz(parts, line, i, path):
    """The three numbers of an STL 'vertex x y z' line."""
    if len(parts) != 4:
        raise MeshFileError(f"mesh file '{path}' line {i}: a vertex needs x y z, got "
                            f"'{line.strip()}'")
    try:
        return [float(x) for x in parts[1:]]
    except ValueError:
        raise MeshFileError(f"mesh file '{path}' line {i}: bad vertex '{line.strip()}'") \
            from None


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
