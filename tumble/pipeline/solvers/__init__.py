"""Constraint solvers: find row impulses within their bounds and apply them to velocities.

Both take the rows of ``joints/common.py`` and the unconstrained velocities, and leave
the constrained velocities and the impulses (N s) of every row.
"""
