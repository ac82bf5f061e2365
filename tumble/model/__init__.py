"""Model layer: the builder, the immutable Model and mass properties."""
from .builder import ModelBuilder
from .model import Model, ModelArrays
from .types import BODY_KINDS, GEOM_TYPES

__all__ = ["ModelBuilder", "Model", "ModelArrays", "BODY_KINDS", "GEOM_TYPES"]
