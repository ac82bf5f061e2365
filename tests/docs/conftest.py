"""tests/docs: the documentation site and its tutorials (helpers in notebooks.py)."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
