"""Reading and writing motion data: BVH motion capture (:mod:`tumble.io.bvh`)."""
from .bvh import Motion, format_bvh, load_bvh, load_bvh_string, save_bvh

__all__ = ["Motion", "format_bvh", "load_bvh", "load_bvh_string", "save_bvh"]
