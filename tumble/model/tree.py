"""Joint trees given as parent indices: the checks and the parents-first order that
motions (``io.bvh``) and skeletons (``character.skeleton``) share."""
import numpy as np

from ..errors import ModelError


def check_tree(joint_names, parents, where):
    """Check J unique names and their parents (-1 for the single root).

    Returns (names list of J str, parents (J,) int64). Raises ModelError prefixed with
    ``where`` for an empty or duplicated name list, a parent out of [-1, J) or a count of
    roots other than one. Cycles are found by ``tree_order``.
    """
    names = [str(n) for n in joint_names]
    J = len(names)
    if J == 0:
        raise ModelError(f"{where}: joint_names is empty")
    if len(set(names)) != J:
        dup = sorted({n for n in names if names.count(n) > 1})
        raise ModelError(f"{where}: duplicate joint names {dup}")
    parents = np.array(parents, dtype=np.int64).reshape(-1)
    if parents.shape != (J,):
        raise ModelError(f"{where}: parents has {parents.size} entries, expected {J}")
    bad = np.flatnonzero((parents < -1) | (parents >= J))
    if bad.size:
        raise ModelError(f"{where}: joint '{names[bad[0]]}' has parent index "
                         f"{parents[bad[0]]} out of range [-1, {J})")
    roots = np.flatnonzero(parents == -1)
    if roots.size != 1:
        raise ModelError(f"{where}: expected exactly one root (parent -1), got "
                         f"{[names[i] for i in roots]}")
    return names, parents


def tree_order(parents, names, where):
    """Depth-first order of the joints, every parent before its children.

    parents : (J,) ints, negative for a root. Returns (order list of J indices, children:
    J lists of child indices in index order). Raises ModelError prefixed with ``where``,
    naming the joints a cycle cuts off from the root.
    """
    J = len(parents)
    children = [[] for _ in range(J)]
    roots = []
    for j, p in enumerate(parents):
        (roots if p < 0 else children[p]).append(j)
    order = []
    stack = roots[::-1]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(children[j][::-1])
    if len(order) != J:
        lost = sorted(set(range(J)) - set(order))
        raise ModelError(f"{where}: joints {[names[j] for j in lost]} are not connected to "
                         "the root (cycle in parents)")
    return order, children
