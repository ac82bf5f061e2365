"""Solve: impulses that satisfy the joint, servo and contact rows together.

The options pick the method: the direct solver (exact, dense or over the joint tree) when
there are no contacts or they are penalty springs; the mixed LCP by Lemke for exact
contacts, with projected Gauss-Seidel standing in if Lemke fails or the contacts have more
rows than the exact path takes (``solvers.mlcp.EXACT_MAX_ROWS``); PGS throughout for
``contact='pgs'`` (or ``solver='pgs'`` without contacts). ``solve_fast`` takes the most
common case (a character on exact contacts) without allocating.

Back-off: a world whose Lemke solve failed skips Lemke (PGS at once) for the next 1, 2, 4,
... up to ``LEMKE_BACKOFF_MAX`` steps while it keeps failing, and tries it every step
again after an exact solve (Lemke's, or ``solve_fast``'s, which resets the back-off). A
pile of redundant contacts (a character lying on the ground: 64 contacts, every face's
corners) makes Lemke fail step after step, each failure costing several times a PGS solve
(measured: 9-11 ms for Lemke against 0.03-1.2 ms for PGS on the fallen course ragdoll); the
back-off keeps that cost to one attempt in ``LEMKE_BACKOFF_MAX + 1`` steps. A step with
fewer contacts than any failure since the last exact solve tries Lemke at once: a
character that gets up from the heap is exact again in the step its contacts drop
(``solve_fast`` guesses from last step's impulses, which PGS's do not give it). While a
world backs off, ``solve_fast`` is not tried either: on the heaps measured (six falls of
the passive ragdoll, the fallen course character) it never solved a step that PGS stood
in for, and its failed guess cost a fifth of the resting heap's step. A refusal by size
(``LEMKE_TOO_LARGE``: more rows than ``EXACT_MAX_ROWS``) starts no back-off, since it
costs nothing: a scene that comes under the limit is solved exactly at once.
"""
import numpy as np
from numba import njit

from .._jit import allocating, noalloc
from .arrays import CONTACT_LCP, CONTACT_PENALTY, CONTACT_PGS, SOLVER_PGS
from .solvers.direct import solve_direct
from .solvers.lemke import LEMKE_SOLVED, LEMKE_TOO_LARGE
from .solvers.mlcp import FAST_GUESS_FAILED, FAST_NOT_HANDLED, guess_on_tree_fast, solve_mlcp
from .solvers.pgs import solve_pgs
from .solvers.tree import make_plan_cache, plan_capacity


# Most steps a world skips Lemke after failures in a row (the window doubles up to it).
LEMKE_BACKOFF_MAX = 1024


# The methods a step's rows are solved by when ``solve_fast`` did not (``solve_method``).
SOLVE_PGS, SOLVE_DIRECT, SOLVE_LCP = 0, 1, 2


@njit(cache=True, inline="always")
def solve_method(o, ncon):
    """The method for rows with ``ncon`` contacts under options ``o``: SOLVE_PGS for
    ``contact='pgs'`` (or ``solver='pgs'`` without contacts: ``solvers.pgs.solve_pgs``),
    SOLVE_DIRECT without contacts or with penalty springs (``solvers.direct.solve_direct``),
    else SOLVE_LCP (``solve_lcp``). The step runs each as a branch of its own."""
    if o.contact == CONTACT_PGS or (o.solver == SOLVER_PGS and ncon == 0):
        return SOLVE_PGS
    if ncon == 0 or o.contact == CONTACT_PENALTY:
        return SOLVE_DIRECT
    return SOLVE_LCP


@allocating
def solve_pgs_rows(m, rows, nrow, inv_inertia, vel, angvel, imp, o):
    """SOLVE_PGS: ``solvers.pgs.solve_pgs`` with the options' sweeps and tolerances on rows
    ``[0, nrow)``; ``vel``, ``angvel`` (nbody, 3) and ``imp`` (nrow,) updated in place.
    (``allocating``, as the other methods: the step's ``noalloc`` code calls them.)"""
    return solve_pgs(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp, o.iterations,
                     o.tolerance, o.velocity_tolerance, o.warm_start)


@allocating
def solve_direct_rows(m, rows, nrow, inv_inertia, vel, angvel, imp, o, cache):
    """SOLVE_DIRECT: ``solvers.direct.solve_direct`` on rows ``[0, nrow)`` (no exact
    contacts among them), its tree plan kept in ``cache`` (``make_solver_caches``' first);
    updated in place as ``solve_pgs_rows``."""
    return solve_direct(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp,
                        o.tolerance, cache)


@allocating
def solve_lcp(m, rows, nrow, ncon, inv_inertia, vel, angvel, imp, o, cache, backoff,
              fast_status):
    """SOLVE_LCP: rows ``[0, nrow)`` with ``ncon`` exact contacts, the mixed LCP by Lemke
    (unless the world backs off from it), PGS from the warm start if Lemke fails;
    updated in place as ``solve_pgs_rows``.

    cache : the mixed LCP's tree-plan cache (``make_solver_caches``' second).
    backoff : (3,) int64 of the world's state (``lcp_backoff``): steps left that skip
        Lemke, the current window, and the fewest contacts of a failure since the last
        exact solve (0: none; module docstring); updated.
    fast_status : what ``solve_fast`` returned for these rows: after FAST_GUESS_FAILED the
        mixed LCP does not try last step's contact state again.
    Returns 1 when PGS stood in for Lemke, else 0."""
    if backing_off(backoff, ncon):
        backoff[0] -= 1
    else:
        backoff[0] = 0          # a window ends early with fewer contacts than at a failure
        status = solve_mlcp(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp,
                            np.int64(0), cache, fast_status != FAST_GUESS_FAILED)
        if status == LEMKE_SOLVED:
            clear_backoff(backoff)
            return 0
        if status != LEMKE_TOO_LARGE:       # (a refusal by size cost nothing: no back-off)
            backoff[1] = min(max(2 * backoff[1], np.int64(1)), np.int64(LEMKE_BACKOFF_MAX))
            backoff[0] = backoff[1]
            backoff[2] = ncon if backoff[2] == 0 else min(backoff[2], ncon)
    solve_pgs(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp, o.iterations,
              o.tolerance, o.velocity_tolerance, o.warm_start)
    return 1


@noalloc
def clear_backoff(backoff):
    """After an exact solve (Lemke's or ``solve_fast``'s): no steps to skip, no window, no
    failure's contact count (``backoff``: see ``solve_lcp``)."""
    for k in range(backoff.shape[0]):
        backoff[k] = 0


@njit(cache=True, inline="always")
def backing_off(backoff, ncon):
    """Whether a step with ``ncon`` contacts skips Lemke (``backoff``: see ``solve_lcp``):
    steps are left in the window and there are no fewer contacts than at a failure."""
    return backoff[0] > 0 and ncon >= backoff[2]


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@noalloc(inline="always")
def solve_fast(m, rows, nrow, ncon, inv_inertia, vel, angvel, imp, o, caches, fast, backoff):
    """``solve_lcp``'s most common case, a character standing or walking on an exact (LCP)
    contact model, without allocating or reference counting (``mlcp.guess_on_tree_fast``).
    Not tried while the world backs off from Lemke (``backoff``, module docstring).
    Returns its status: FAST_SOLVED when it solved the rows; otherwise everything is left
    to the method ``solve_method`` picks (given the status)."""
    if o.contact != CONTACT_LCP or ncon == 0 or backing_off(backoff, ncon):
        return FAST_NOT_HANDLED
    return guess_on_tree_fast(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp,
                              caches[1], fast)


@njit(cache=True)
def make_solver_caches(m, servoed, nbody):
    """Tree-plan caches of the direct solver and of the mixed LCP for one ``step`` call:
    the joints' (and body servos') rows keep their plan from step to step."""
    nrow, nfac = plan_capacity(m.joint_parent, m.joint_child, m.joint_row_count, servoed,
                               m.body_inv_mass, nbody)
    return (make_plan_cache(nrow, nbody, nfac), make_plan_cache(nrow, nbody, nfac))
