"""Joint trees as parent indices: the shared checks of motions and skeletons."""
import numpy as np
import pytest

from tumble.errors import ModelError
from tumble.model.tree import check_tree, tree_order


def test_order_puts_parents_first_and_lists_children_in_index_order():
    names, parents = check_tree(["a", "b", "c", "d"], [2, 2, -1, 0], "t")
    assert names == ["a", "b", "c", "d"] and parents.dtype == np.int64
    order, children = tree_order(parents, names, "t")
    assert order == [2, 0, 3, 1]
    assert children == [[3], [], [0, 1], []]


@pytest.mark.parametrize("names, parents, match", [
    ([], [], "t: joint_names is empty"),
    (["a", "a"], [-1, 0], r"t: duplicate joint names \['a'\]"),
    (["a", "b"], [-1], "t: parents has 1 entries, expected 2"),
    (["a", "b"], [-1, 5], r"t: joint 'b' has parent index 5 out of range \[-1, 2\)"),
    (["a", "b"], [-1, -1], "t: expected exactly one root"),
])
def test_check_tree_refuses_bad_trees(names, parents, match):
    with pytest.raises(ModelError, match=match):
        check_tree(names, parents, "t")


def test_tree_order_names_the_joints_a_cycle_cuts_off():
    with pytest.raises(ModelError, match=r"t: joints \['b', 'c'\] are not connected"):
        tree_order(np.array([-1, 2, 1]), ["a", "b", "c"], "t")
