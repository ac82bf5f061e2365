"""Type codes: the one home of every integer code stored in a model or read by a kernel.

Each set is a group of int constants plus, where users name them, a dict from the
user-facing name to the code. The builder, the loaders and the pipeline kernels all
import them from here.
"""

# Body kinds (``Model.body_kind``): dynamic bodies move under forces; kinematic bodies
# follow their set velocity; static bodies never move. Kinematic and static bodies have
# infinite mass.
DYNAMIC, KINEMATIC, STATIC = 0, 1, 2
BODY_KINDS = {"dynamic": DYNAMIC, "kinematic": KINEMATIC, "static": STATIC}

# Geom shape types (``Model.geom_type``); sizes and frames are described in
# ``pipeline.collision.shapes``. HEIGHTFIELD is static terrain only.
PLANE, SPHERE, CAPSULE, BOX, CYLINDER, CONVEX, HEIGHTFIELD = 0, 1, 2, 3, 4, 5, 6
NUM_GEOM_TYPES = 7
GEOM_TYPES = {"plane": PLANE, "sphere": SPHERE, "capsule": CAPSULE, "box": BOX,
              "cylinder": CYLINDER, "convex": CONVEX, "heightfield": HEIGHTFIELD}

# Joint types (``Model.joint_type``), with the constraint rows that hold each type
# together (CORE_ROWS) and its degrees of freedom (DOFS).
FREE, BALL, HINGE, UNIVERSAL, FIXED, SLIDER = 0, 1, 2, 3, 4, 5
JOINT_TYPES = {"free": FREE, "ball": BALL, "hinge": HINGE, "universal": UNIVERSAL,
               "fixed": FIXED, "slider": SLIDER}
CORE_ROWS = {FREE: 0, BALL: 3, HINGE: 5, UNIVERSAL: 4, FIXED: 6, SLIDER: 5}
DOFS = {FREE: 0, BALL: 3, HINGE: 1, UNIVERSAL: 2, FIXED: 0, SLIDER: 1}
# Per degree of freedom: a limit row, a motor row, a damping row and a friction row.
ROWS_PER_DOF = 4

# Actuator kinds (``Model.act_kind``): a motor applies gear * ctrl; a position actuator
# is a PD servo towards ctrl.
ACT_MOTOR, ACT_POSITION = 0, 1
ACTUATOR_KINDS = {"motor": ACT_MOTOR, "position": ACT_POSITION}

# Broad-phase methods (a world option): sort and sweep, or a hashed uniform grid.
BROADPHASE_SAP, BROADPHASE_GRID = 0, 1
BROADPHASES = {"sap": BROADPHASE_SAP, "grid": BROADPHASE_GRID}
