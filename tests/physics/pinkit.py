"""A tree of physkit.Link built in Pinocchio (an independent rigid-body dynamics code), and its mass matrix and
accelerations converted to our coordinates. Built from the test's own description of the mechanism, not from
anything the compiler produced.

Pinocchio's joint frame is our frame b of the joint (it coincides with frame a at zero coordinates); a body is
appended to its joint at the pose of its part frame in frame b. Composite joints (universal, cylindrical,
planar, cardan rotations) are Pinocchio composites of single-axis joints, whose velocities are the coordinate
rates, as ours. Pinocchio orders quaternions (x, y, z, w), and its free-flyer linear velocity is R^T pdot
(child frame) where ours is pdot (parent frame).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from physkit import EYE, quat_matrix


def _se3(R, r):
    return pin.SE3(np.array(R, dtype=float), np.array(r, dtype=float).reshape(3))


def _composite(*joints):
    c = pin.JointModelComposite(len(joints))
    for j in joints:
        c.addJoint(j)
    return c


def _joint(link):
    rev = lambda a: pin.JointModelRevoluteUnaligned(np.asarray(a, dtype=float))  # noqa: E731
    pri = lambda a: pin.JointModelPrismaticUnaligned(np.asarray(a, dtype=float))  # noqa: E731
    axes = [np.asarray(a, float) / np.linalg.norm(a) for a in link.axes]
    kind = link.kind
    if kind == "revolute":
        return rev(axes[0])
    if kind == "prismatic":
        return pri(axes[0])
    if kind == "cylindrical":
        return _composite(pri(axes[0]), rev(axes[0]))
    if kind == "universal":
        return _composite(rev(axes[0]), rev(axes[1]))
    if kind == "planar":
        n, u = axes
        return _composite(pri(u), pri(np.cross(n, u)), rev(n))
    if kind == "cardan":
        return _composite(*(rev(e) for e in EYE))
    if kind == "free_cardan":
        return _composite(*(pri(e) for e in EYE), *(rev(e) for e in EYE))
    if kind == "spherical":
        return pin.JointModelSpherical()
    if kind == "free":
        return pin.JointModelFreeFlyer()
    raise ValueError(kind)


class PinTree:
    """The Pinocchio model of `links` under `gravity`, evaluated at states given by name."""

    def __init__(self, links, gravity):
        self.links = links
        model = pin.Model()
        model.gravity = pin.Motion(np.asarray(gravity, dtype=float), np.zeros(3))
        # part index -> (Pinocchio joint id, pose of the part frame in that joint's frame)
        frame_of = {-1: (0, pin.SE3.Identity())}
        self.joint_id = {}
        for i, link in enumerate(links):
            jid_parent, X_part = frame_of[link.parent]
            Xa = X_part * _se3(link.Ra, link.ra)
            Xb_inv = _se3(link.Rb, link.rb).inverse()
            inertia = pin.Inertia(float(link.mass), np.asarray(link.com, float), np.asarray(link.inertia, float))
            if link.kind == "fixed":
                frame_of[i] = (jid_parent, Xa * Xb_inv)
                model.appendBodyToJoint(jid_parent, inertia, frame_of[i][1])
                continue
            jid = model.addJoint(jid_parent, _joint(link), Xa, link.name)
            model.appendBodyToJoint(jid, inertia, Xb_inv)
            frame_of[i] = (jid, Xb_inv)
            self.joint_id[i] = jid
        self.model, self.data = model, model.createData()

    def _state(self, values: dict, v_names) -> tuple:
        """(q, v, P, where, free): Pinocchio's state for our named values, v_pin = P v_ours, our speed name ->
        Pinocchio velocity index, and the free joints (Pinocchio linear index, our pdot indices, R)."""
        model = self.model
        q = np.zeros(model.nq)
        our = {n: k for k, n in enumerate(v_names)}
        nv = model.nv
        P = np.zeros((nv, nv))
        where, free = {}, []
        for i, link in enumerate(self.links):
            if link.kind == "fixed":
                continue
            jm = model.joints[self.joint_id[i]]
            iq, iv = jm.idx_q, jm.idx_v
            qn, vn = link.coordinates()
            qs = np.array([values[n] for n in qn])
            if link.kind in ("spherical", "free"):
                k = 3 if link.kind == "free" else 0
                quat = qs[k:] / np.linalg.norm(qs[k:])
                q[iq:iq + k] = qs[:k]
                q[iq + k:iq + k + 4] = [*quat[1:], quat[0]]
            else:
                q[iq:iq + len(qs)] = qs
            for k, name in enumerate(vn):
                where[name] = iv + k
                P[iv + k, our[name]] = 1.0
            if link.kind == "free":
                R = quat_matrix(qs[3:])
                cols = [our[n] for n in vn[:3]]
                P[iv:iv + 3, :] = 0.0
                P[iv:iv + 3, cols] = R.T
                free.append((iv, cols, R))
        v = P @ np.array([values[n] for n in v_names])
        return q, v, P, where, free

    def dynamics(self, values: dict, v_names) -> tuple[np.ndarray, np.ndarray]:
        """(M, vdot) in our velocity coordinates, rows in the order of `v_names`."""
        model = self.model
        q, v, P, where, free = self._state(values, v_names)
        M_pin = np.array(pin.crba(model, self.data, q))
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        a_pin = np.array(pin.aba(model, self.data, q, v, np.zeros(model.nv)))
        vdot = np.array([a_pin[where[n]] for n in v_names])
        for iv, cols, R in free:
            # pdot = R v_lin  =>  pddot = R (a_lin + omega x v_lin)
            vdot[cols] = R @ (a_pin[iv:iv + 3] + np.cross(v[iv + 3:iv + 6], v[iv:iv + 3]))
        return P.T @ M_pin @ P, vdot

    def joint_loads(self, values: dict, v_names) -> dict:
        """Per link index (fixed joints excepted): (force, moment) [N, N*m] its joint transmits onto the child
        body in free motion (no joint torques), in the joint frame (our frame b), moment about its origin:
        Pinocchio's rnea body forces data.f at the accelerations of its own aba."""
        model = self.model
        q, v, _, _, _ = self._state(values, v_names)
        a = pin.aba(model, self.data, q, v, np.zeros(model.nv))
        pin.rnea(model, self.data, q, v, a)
        return {i: (np.array(self.data.f[jid].linear), np.array(self.data.f[jid].angular))
                for i, jid in self.joint_id.items()}
