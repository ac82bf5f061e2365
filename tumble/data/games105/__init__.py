"""The GAMES-105 course reference character (BSD 3-Clause, see LICENSE)."""
