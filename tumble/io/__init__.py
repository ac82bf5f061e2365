"""Reading and writing model and motion files: BVH motion capture (:mod:`tumble.io.bvh`),
MuJoCo MJCF models (:mod:`tumble.io.mjcf`) and URDF robots (:mod:`tumble.io.urdf`).

Every file that cannot be read raises a ``ModelError`` naming it (a missing one
:class:`MissingFileError`, which is also a ``FileNotFoundError``), and the readers stop at
caps, each named in its error: BVH ``bvh.MAX_FILE_BYTES`` (256 MiB), ``bvh.MAX_DEPTH``
(1,000 nested joints) and ``bvh.MAX_VALUE`` (1e9, the largest offset or channel value);
MJCF and URDF ``_xml.MAX_XML_BYTES`` (32 MiB of XML per model, includes counted),
``_xml.MAX_ELEMENTS`` (200,000) and ``_xml.MAX_DEPTH`` (1,000 nested elements); MJCF
``mjcf.MAX_INCLUDES`` (1,000) and ``mjcf.MAX_INCLUDE_DEPTH`` (20); mesh files
``_meshfile.MAX_MESH_BYTES`` (256 MiB); state files ``_files.MAX_STATE_BYTES`` (1 GiB
unpacked). The parsers walk trees with explicit stacks, so any depth up to the caps works.
"""
from ._files import MissingFileError
from .bvh import Motion, format_bvh, load_bvh, load_bvh_string, save_bvh
from .mjcf import load_mjcf, parse_mjcf
from .urdf import load_urdf, parse_urdf

__all__ = ["Motion", "format_bvh", "load_bvh", "load_bvh_string", "save_bvh", "load_mjcf",
           "parse_mjcf", "load_urdf", "parse_urdf", "MissingFileError"]
