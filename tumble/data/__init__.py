"""Data files shipped with tumble (see each folder's README and LICENSE)."""
