"""Joint type codes and the number of core rows and degrees of freedom of each."""
FREE, BALL, HINGE, UNIVERSAL, FIXED, SLIDER = 0, 1, 2, 3, 4, 5
JOINT_TYPES = {"free": FREE, "ball": BALL, "hinge": HINGE, "universal": UNIVERSAL,
               "fixed": FIXED, "slider": SLIDER}
CORE_ROWS = {FREE: 0, BALL: 3, HINGE: 5, UNIVERSAL: 4, FIXED: 6, SLIDER: 5}
DOFS = {FREE: 0, BALL: 3, HINGE: 1, UNIVERSAL: 2, FIXED: 0, SLIDER: 1}
# Per degree of freedom: a limit row, a motor row, a damping row and a friction row.
ROWS_PER_DOF = 4
