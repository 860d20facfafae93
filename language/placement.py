"""Geometry of parts: frame placements, rotations, axes, mirror images and mass geometry.

Part of the elaborator (mixed into Elaborator): turns the AST of parts, frames, bodies and ports into the
data model's Frame and Body objects, with the instance's mirror applied.
"""

from __future__ import annotations

import numpy as np

from . import ast
from . import expr as X
from . import geometry as G
from . import model as M
from . import units as U
from .expressions import ExprResolver, Invalid
from .scope import InstanceEntry, PartEntry, PortEntry, Scope, did_you_mean
from . import catalog


class PlacementMixin:
    def build_part(self, scope: Scope, st: ast.Part) -> M.Part:
        full = scope.full(st.name.text)
        body = self.build_body(scope, st) if st.body is not None else None
        frames = self._frames_of(full, scope, st.frames, body)
        return M.Part(full, tuple(frames), body, st.description, scope.at(st.span))

    def _frames_of(self, part: str, scope: Scope, decls, body) -> list[M.Frame]:
        frames = [M.Frame(M.ORIGIN, G.ZERO_VEC, G.IDENTITY, scope.at(scope.block.name.span))]
        if body is not None:
            frames.append(M.Frame("com", body.com, G.IDENTITY, body.span))
        for f in decls:
            try:
                position, rotation = self.frame_pose(scope, f)
            except Invalid:
                continue
            frames.append(M.Frame(f.name.text, position, rotation, scope.at(f.span)))
        return frames

    def frame_pose(self, scope: Scope, f: ast.Frame) -> tuple[M.Vec3, M.Mat3]:
        r = ExprResolver(self, scope, allow_state=False, what=f"the position of frame '{f.name.text}'")
        position = G.ZERO_VEC
        if f.at is not None:
            position, dim = r.vector(f.at, "a frame position")
            r.expect(dim, U.LENGTH, f.at.span, "a frame position")
        rotation = self.rotation(scope, f.rotate) if f.rotate is not None else G.IDENTITY
        return G.mirror_vec(scope.signs, position), G.mirror_mat(scope.signs, rotation)

    def build_port_frames(self, scope: Scope, st: ast.Port) -> None:
        port = scope.entries.get(st.name.text)
        if not isinstance(port, PortEntry) or port.part is None:
            return
        base = self.base_pose(port.part, port.base_frame)
        for f in st.frames:
            try:
                p, R = self.frame_pose(scope, f)
            except Invalid:
                continue
            if base is not None:
                bp, bR = base
                p, R = G.vadd(bp, G.matvec(bR, p)), G.matmul(bR, R)
            self.part_frames.setdefault(port.part, []).append(M.Frame(port.frame_prefix + f.name.text, p, R,
                                                                      scope.at(f.span)))

    def base_pose(self, part: str, frame: str):
        """Pose of a frame a port is bound to (frames declared directly on the part, or the origin)."""
        if frame == M.ORIGIN:
            return None
        entry = self.part_entry(part)
        if entry is None:
            return None
        decls = entry.decl.frames if entry.decl is not None else self.inertial_frames
        for f in decls:
            if f.name.text == frame:
                scope = self._scope_of_part(self.root, part) or self.root
                return self.frame_pose(scope, f)
        for fr in self.part_frames.get(part, []):
            if fr.name == frame:
                return fr.position, fr.rotation
        return None

    def _scope_of_part(self, scope: Scope, full: str) -> Scope | None:
        for entry in scope.entries.values():
            if isinstance(entry, PartEntry) and entry.full == full:
                return scope
            if isinstance(entry, InstanceEntry):
                found = self._scope_of_part(entry.scope, full)
                if found:
                    return found
        return None

    def rotation(self, scope: Scope, node: ast.Expr) -> M.Mat3:
        """axis_angle(axis, angle) | cardan(a, b, c) | euler(a, b, c) | angles(seq, a, b, c) | dcm([[...]])"""
        r = ExprResolver(self, scope, allow_state=False, what="a frame rotation")
        if not isinstance(node, ast.Call):
            raise r.error("a rotation is axis_angle(axis, angle), cardan(a, b, c), euler(a, b, c), "
                          "angles(xyz, a, b, c) or dcm([[...], [...], [...]])", node.span)
        fn, args = node.func.dotted, node.args

        def angle(a):
            value, dim = r.scalar(a)
            r.expect(dim, U.ANGLE, a.span, "an angle")
            return value
        if fn == "axis_angle" and len(args) == 2:
            return G.axis_rotation(self.axis(scope, args[0], "a rotation axis"), angle(args[1]))
        if fn in ("cardan", "euler") and len(args) == 3:
            return G.sequence_rotation("xyz" if fn == "cardan" else "zxz", tuple(angle(a) for a in args))
        if fn == "angles" and len(args) == 4:
            seq = args[0].ref.dotted if isinstance(args[0], ast.Name) else ""
            if len(seq) != 3 or any(c not in "xyz" for c in seq) or seq[0] == seq[1] or seq[1] == seq[2]:
                raise r.error("a rotation sequence is three axes such as xyz, zyx or zxz", args[0].span)
            return G.sequence_rotation(seq, tuple(angle(a) for a in args[1:]))
        if fn == "dcm" and len(args) == 1:
            return self.dcm(r, args[0])
        raise r.error(f"unknown rotation '{fn}' with {len(args)} arguments; use axis_angle(axis, angle), "
                      f"cardan(a, b, c), euler(a, b, c), angles(seq, a, b, c) or dcm([[...]])", node.span)

    def dcm(self, r: ExprResolver, node) -> M.Mat3:
        rows = self.matrix(r, node, "a direction-cosine matrix")
        values = [[self.constant(e, r.scope, node.span) for e in row] for row in rows]
        a = np.array(values)
        with np.errstate(all="ignore"):  # huge entries overflow here: not a rotation either way
            proper = np.all(np.isfinite(a)) and np.allclose(a @ a.T, np.eye(3), atol=1e-6) and np.linalg.det(a) > 0
        if not proper:
            raise r.error("a direction-cosine matrix must be a proper rotation (orthonormal, determinant +1)",
                          node.span)
        return rows

    def matrix(self, r: ExprResolver, node, what: str) -> M.Mat3:
        factor, unit_dim, inner = 1.0, None, node
        if isinstance(node, ast.WithUnit):
            factor, unit_dim = r.unit(node.unit, node.unit_span)
            inner = node.expr
        if not (isinstance(inner, ast.Matrix) and len(inner.items) == 3 and
                all(isinstance(row, ast.Matrix) and len(row.items) == 3 for row in inner.items)):
            raise r.error(f"{what} is a 3x3 matrix [[a, b, c], [d, e, f], [g, h, i]]", node.span)
        rows = []
        for row in inner.items:
            rows.append(tuple(X.mul(r.scalar(c)[0], X.const(factor)) for c in row.items))
        self._matrix_dim = unit_dim
        return tuple(rows)  # type: ignore[return-value]

    def axis(self, scope: Scope, node: ast.Expr, what: str, axial: bool = False) -> M.Vec3:
        """x, y, z, -x, ... or a vector; normalised (with a note when the user's vector was not unit)."""
        r = ExprResolver(self, scope, allow_state=False, what=what)
        negate = False
        inner = node
        if isinstance(inner, ast.Unary) and inner.op == "-":
            negate, inner = True, inner.operand
        if isinstance(inner, ast.Name) and inner.ref.dotted in G.UNIT_AXES:
            vec = G.const_vec(tuple(-c if negate else c for c in G.UNIT_AXES[inner.ref.dotted]))
        else:
            vec, _ = r.vector(node, what)
            if all(isinstance(c, X.Const) for c in vec):
                values = tuple(c.value for c in vec)
                unit = G.normalise_constant(values)
                if unit is None:
                    raise r.error(f"{what} must not be zero", node.span)
                if abs(sum(v * v for v in values) - 1.0) > 1e-12:
                    self.diags.note(f"{what} normalised to ({', '.join('%.6g' % v for v in unit)})",
                                    scope.at(node.span))
                vec = G.const_vec(unit)
            else:
                vec = G.normalise(vec)
        return G.mirror_axial(scope.signs, vec) if axial else G.mirror_vec(scope.signs, vec)

    def build_body(self, scope: Scope, st: ast.Part) -> M.Body | None:
        settings = {}
        for s in st.body.settings:
            if s.name.text not in catalog.BODY_SETTINGS:
                self.diags.error(f"unknown body property '{s.name.text}'"
                                 f"{did_you_mean(s.name.text, catalog.BODY_SETTINGS)}", scope.at(s.name.span))
            elif s.name.text in settings:
                self.diags.error(f"'{s.name.text}' is given twice", scope.at(s.name.span))
            else:
                settings[s.name.text] = s
        for required in ("mass", "inertia"):
            if required not in settings:
                self.diags.error(f"body of '{st.name.text}' has no {required}", scope.at(st.body.span))
        if len(settings) != len(st.body.settings) or "mass" not in settings or "inertia" not in settings:
            return None
        r = ExprResolver(self, scope, allow_state=False, what="a body property")
        try:
            mass, dim = r.scalar(settings["mass"].value)
            r.expect(dim, U.MASS, settings["mass"].value.span, "mass")
            com = G.ZERO_VEC
            if "com" in settings:
                com, dim = r.vector(settings["com"].value, "the centre of mass")
                r.expect(dim, U.LENGTH, settings["com"].value.span, "the centre of mass")
            for s in settings.values():
                if s.about is not None and s.name.text != "inertia":
                    raise r.error("only an inertia is given 'about' a frame", s.about.span)
            inertia = self.inertia(scope, r, settings["inertia"])
            if settings["inertia"].about is not None:
                inertia = self.inertia_about_com(scope, r, st, settings["inertia"], inertia, mass, com)
        except Invalid:
            return None
        about = settings["inertia"].about
        return M.Body(mass, G.mirror_vec(scope.signs, com), G.mirror_mat(scope.signs, inertia),
                      scope.at(st.body.span), about.dotted if about is not None else "")

    def inertia_about_com(self, scope: Scope, r: ExprResolver, st: ast.Part, s: ast.Setting, inertia: M.Mat3,
                          mass: X.E, com: M.Vec3) -> M.Mat3:
        """An inertia given about a frame's origin F, shifted to the centre of mass C (parallel-axis theorem):
        I_C = I_F - m (|d|^2 E - d d^T) with d = r_F - r_C in part axes. Whether the result is a body's inertia
        (positive semi-definite, triangle inequalities) is checked with the others (rules.check_body)."""
        name = s.about.dotted
        if name == M.ORIGIN:
            position = G.ZERO_VEC
        elif name == "com":
            return inertia
        else:
            frame = next((f for f in st.frames if f.name.text == name), None)
            if frame is None:
                names = [M.ORIGIN, "com", *(f.name.text for f in st.frames)]
                raise r.error(f"no frame '{name}' on part '{st.name.text}'{did_you_mean(name, names)} "
                              "(an inertia is given about a frame of its own part)", s.about.span)
            position, _ = self.frame_pose(scope, frame)
            position = G.mirror_vec(scope.signs, position)  # frame_pose mirrored it; inertia is mirrored later
        d = tuple(G.sub(position[i], com[i]) for i in range(3))
        d2 = X.add(X.add(X.mul(d[0], d[0]), X.mul(d[1], d[1])), X.mul(d[2], d[2]))
        shifted = []
        for i in range(3):
            row = []
            for j in range(3):
                steiner = X.mul(d[i], d[j])
                steiner = G.sub(d2, steiner) if i == j else X.neg(steiner)
                row.append(G.sub(inertia[i][j], X.mul(mass, steiner)))
            shifted.append(tuple(row))
        return tuple(shifted)  # type: ignore[return-value]

    def inertia(self, scope: Scope, r: ExprResolver, s: ast.Setting) -> M.Mat3:
        node = s.value
        factor, unit_dim, inner = 1.0, None, node
        if isinstance(node, ast.WithUnit):
            factor, unit_dim = r.unit(node.unit, node.unit_span)
            inner = node.expr
        if isinstance(inner, ast.Call) and inner.func.dotted == "diag" and len(inner.args) == 3:
            diag = []
            for a in inner.args:
                value, dim = r.scalar(a)
                if unit_dim is not None:
                    value, dim = X.mul(value, X.const(factor)), unit_dim
                r.expect(dim, U.INERTIA, a.span, "an inertia")
                diag.append(value)
            tensor = tuple(tuple(diag[i] if i == j else X.ZERO for j in range(3)) for i in range(3))
        elif isinstance(inner, ast.Matrix):
            tensor = self.matrix(r, node, "an inertia tensor")
            r.expect(self._matrix_dim, U.INERTIA, node.span, "an inertia")
        else:
            raise r.error("an inertia is diag(Ixx, Iyy, Izz) or a symmetric 3x3 matrix [[..], [..], [..]] "
                          "(about the centre of mass)", node.span)
        if s.frame is not None:
            # components given in the axes of a frame of this part: I_part = R I R^T
            frame = next((f for f in _part_frames(s, scope) if f.name.text == s.frame.dotted.split(".")[-1]), None)
            if frame is None or frame.rotate is None:
                if frame is None:
                    raise r.error(f"no frame '{s.frame.dotted}' on this part", s.frame.span)
            else:
                R = self.rotation(scope, frame.rotate)
                tensor = G.matmul(G.matmul(R, tensor), G.transpose(R))
        return tensor  # type: ignore[return-value]


def _part_frames(setting: ast.Setting, scope: Scope):
    for st in scope.block.statements:
        if isinstance(st, ast.Part) and st.body is not None and any(s is setting for s in st.body.settings):
            return st.frames
    return ()
