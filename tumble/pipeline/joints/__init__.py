"""Joint constraint rows, one module per joint type; ``rows.py`` dispatches on the type.

Each type module provides ``core_rows`` (the rows that hold the joint together) and
``dofs`` (the axes and coordinates of its free motion, which limits, motors, damping
and friction act on). Adding a type means one module and one entry in ``rows.py``;
the solvers only ever see rows.
"""
