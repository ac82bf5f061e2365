"""Reading and writing model and motion files: BVH motion capture (:mod:`tumble.io.bvh`),
MuJoCo MJCF models (:mod:`tumble.io.mjcf`) and URDF robots (:mod:`tumble.io.urdf`)."""
from .bvh import Motion, format_bvh, load_bvh, load_bvh_string, save_bvh
from .mjcf import load_mjcf, parse_mjcf
from .urdf import load_urdf, parse_urdf

__all__ = ["Motion", "format_bvh", "load_bvh", "load_bvh_string", "save_bvh", "load_mjcf",
           "parse_mjcf", "load_urdf", "parse_urdf"]
