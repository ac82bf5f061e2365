"""Tasks of the learning package: what is observed, done and rewarded, over N worlds."""
from .imitation import ImitationEnv, deepmimic_gains

__all__ = ["ImitationEnv", "deepmimic_gains"]
