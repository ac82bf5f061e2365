"""Constraint solvers: find row impulses within their bounds and apply them to velocities.

Each takes the rows of ``joints/common.py`` and the unconstrained velocities, and leaves
the constrained velocities and the impulses (N s) of every row.

    common.py      rows, bodies, applying an impulse
    pgs.py         projected Gauss-Seidel
    tree.py        linear-time factorisation of tree-structured rows
    direct.py      the box-bounded active-set solve (dense or over the tree)
    lemke.py       Lemke's method for an LCP
    mlcp.py        the mixed LCP of contacts and joints, exact, which uses:
      partition.py   the rows by kind
      schur.py       the Schur complement of the bilateral rows
      guess.py       last step's contact state as the active set
      pyramid.py     the friction-pyramid LCP, by Lemke
"""
