"""The GAMES-105 course's own setup on ODE (panda3d.ode): the reference character, root
pinned, joints held in the T-pose by explicit PD torques recomputed in NumPy every substep.

    pip install panda3d scipy
    python bench/peers/ode_games105.py [CHARACTER.npy] [SECONDS [SUBSTEPS [KP KD]]]

Defaults: bench/data/character_model.npy, 5 s, 32 substeps per 60 Hz frame (dt = 1/1920 s),
kp = 300 N m/rad, kd = 20 N m s/rad. The character is built as bench/data/README.md
describes (boxes of the course's sizes, inflated inertia, Y up). Prints one
``RESULT {json}`` line: wall time per simulated second and the final joint error (rad).
"""
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation as R
from panda3d.core import BitMask32, Vec4
from panda3d.ode import (OdeBallJoint, OdeBody, OdeBoxGeom, OdeHingeJoint, OdeJointGroup,
                         OdeMass, OdePlaneGeom, OdeSimpleSpace, OdeWorld)

DATA = Path(__file__).resolve().parents[1] / "data" / "character_model.npy"
NBODY = 20          # joints 20..24 are end sites without a body
TORQUE_LIMIT = 200.0  # N m, the course's clip on every PD torque component


def box_scales(names):
    """The course's box size vector s (m) per joint; collision boxes are 1.5 s, mass boxes 10 s."""
    t = 0.03
    scale = {n: [t] * 3 for n in names[:NBODY]}
    scale.update(RootJoint=[0.06, 0.06, 0.04], torso_head=[0.05, 0.08, 0.04],
                 lowerback_torso=[t, 0.04, 0.04], pelvis_lowerback=[t, 0.035, 0.04])
    for s in "lr":
        scale.update({s + "Hip": [t, 0.15, t], s + "Knee": [t, 0.16, t],
                      s + "Ankle": [t * 1.5, t * 0.8, 0.07],
                      s + "ToeJoint": [t * 1.5, t * 0.6, 0.02],
                      s + "Torso_Clavicle": [0.05, t, t], s + "Shoulder": [0.07, t, t],
                      s + "Elbow": [0.07, t, t], s + "Wrist": [0.05, t * 0.6, t * 1.1]})
    return scale


def build(info):
    """ODE world, contact group, space and the 20 bodies of the character (root pinned)."""
    names, jpos, bpos = info["joint_name"], info["joint_pos"], info["body_pos"]
    parent = info["parent"]
    world = OdeWorld()
    world.setGravity(0, -9.81, 0)
    # surface 0: mu 1.5, no bounce, ERP 0.9, CFM 0.001 (the course's contact softness)
    world.initSurfaceTable(1)
    world.setSurfaceEntry(0, 0, 1.5, 0.0, 0, 0.9, 0.001, 0.0, 0.0)
    space = OdeSimpleSpace()
    contacts = OdeJointGroup()
    space.setAutoCollideWorld(world)
    space.setAutoCollideJointGroup(contacts)
    ground = OdePlaneGeom(space, Vec4(0, 1, 0, 0))
    ground.setCollideBits(BitMask32(1))
    ground.setCategoryBits(BitMask32(1))
    scale = box_scales(names)
    bodies, geoms = [], []
    for i in range(NBODY):
        n, s = names[i], scale[names[i]]
        toe = "Toe" in n
        pos = np.array(bpos[i], float)
        if toe:
            pos[1] += 0.01
        b = OdeBody(world)
        b.setPosition(*pos)
        m = OdeMass()
        m.setBox(100 if toe else 50, *[10 * x for x in s])
        b.setMass(m)
        g = OdeBoxGeom(space, *[1.5 * x for x in s])
        g.setBody(b)
        bits = BitMask32(0 if toe else 1)       # toes do not collide
        g.setCollideBits(bits)
        g.setCategoryBits(bits)
        if toe or "Elbow" in n or "Knee" in n:
            j = OdeHingeJoint(world)
            j.attach(b, bodies[parent[i]])
            j.setAnchor(*jpos[i])
            j.setAxis((0, 1, 0) if "Elbow" in n else (1, 0, 0))
        else:                                   # the root's ball joint pins it to the world
            j = OdeBallJoint(world)
            j.attach(b, bodies[parent[i]] if i else None)
            j.setAnchor(*jpos[i])
        bodies.append(b)
        geoms.append(g)
    return world, space, contacts, bodies, geoms


def main():
    argv = sys.argv[1:]
    path = argv.pop(0) if argv and argv[0].endswith(".npy") else str(DATA)
    seconds = float(argv[0]) if len(argv) > 0 else 5.0
    substep = int(argv[1]) if len(argv) > 1 else 32
    kp, kd = (float(argv[2]), float(argv[3])) if len(argv) > 3 else (300.0, 20.0)
    info = np.load(path, allow_pickle=True).item()
    world, space, contacts, bodies, _geoms = build(info)
    par = np.array(info["parent"][:NBODY])
    kids = np.arange(1, NBODY)

    def state():
        q = np.array([[b.getQuaternion()[k] for k in (1, 2, 3, 0)] for b in bodies])   # x, y, z, w
        w = np.array([list(b.getAngularVel()) for b in bodies])
        return q, w

    def pd():
        """World-frame PD torques towards the T-pose: +tau on the child, -tau on the parent.
        Returns the largest joint error component (rad) before the torques act."""
        q, w = state()
        rc, rp = R.from_quat(q[kids]), R.from_quat(q[par[kids]])
        err = -(rp.inv() * rc).as_rotvec()
        wrel = rp.inv().apply(w[kids] - w[par[kids]])
        tau = rp.apply(np.clip(kp * err - kd * wrel, -TORQUE_LIMIT, TORQUE_LIMIT))
        for k, c in enumerate(kids):
            bodies[c].addTorque(*tau[k])
            bodies[par[c]].addTorque(*(-tau[k]))
        return float(np.abs(err).max())

    frames = int(seconds * 60)
    dt = 1.0 / (60 * substep)
    err = 0.0
    t0 = time.perf_counter()
    for _ in range(frames):
        for _ in range(substep):
            err = pd()
            space.autoCollide()
            world.step(dt)          # the course uses dWorldStep (exact LCP), not quickStep
            contacts.empty()
    wall = time.perf_counter() - t0
    q, _ = state()
    print("RESULT " + json.dumps(dict(
        engine="ode (panda3d)", scene="games105 T-pose hold, root pinned", substep=substep,
        dt=dt, sim_s=seconds, wall_s=wall, wall_per_sim_s=wall / seconds,
        ms_per_substep=wall / (frames * substep) * 1e3, max_joint_err_rad_end=err,
        finite=bool(np.all(np.isfinite(q))), kp=kp, kd=kd)), flush=True)


if __name__ == "__main__":
    main()
