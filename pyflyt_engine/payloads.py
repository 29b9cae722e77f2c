"""Payloads: rigid bodies declared in an env config and attached to the vehicle or the world.

A payload is one rigid body (a pole, a ball, a cup, a race gate) described like an
airframe's body -- shapes, mass and inertia in SI units (:class:`~pyflyt_engine.spec.BodySpec`)
-- plus how it is held (:class:`AttachSpec`):

==========  ===================================================================
joint       meaning
==========  ===================================================================
``fixed``   welded to its parent (a cup on the vehicle; a gate fixed in the world,
            which is then a static body)
``ball``    a passive spherical joint at ``anchor``: free to rotate about the
            point, no friction (a pole balanced on the vehicle)
``tether``  an inextensible string of length ``length`` from ``anchor`` to
            ``payload_anchor``: the distance between the two points is at most
            ``length``, the string can go slack (a ball on a string)
``free``    no joint: placed relative to its parent at every reset, then free
==========  ===================================================================

Frames: a payload's ``shapes`` and ``payload_anchor`` are in its own frame (any reference
point: the body origin is moved to its centre of mass, as for airframes).  ``position`` and
``orientation`` place that frame relative to the parent at every reset: in the vehicle's
body frame (origin at the vehicle's centre of mass, x forward, y left, z up) for
``to: vehicle``, in the ground frame (ENU) for ``to: world``.  ``anchor`` is a point of the
parent in the same frame.

The tether is a two-link body: a massless-in-effect pivot (1 g sphere, no collision) held
at ``anchor`` by a point-to-point constraint, and the payload on a frictionless prismatic
joint along the pivot-to-payload direction, limited to ``[0, length]`` (PyBullet's joint
limit is one-sided in effect: it stops the payload at full length and lets it come
closer).  URDF text is generated from the spec and cached by digest like an airframe's
(:func:`pyflyt_engine.urdf.cached_urdf`).

Everything here but :class:`PayloadSet` is plain data; :class:`PayloadSet` is the one
adapter that talks to PyBullet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from pyflyt_engine import exact
from pyflyt_engine.frames import matrix_to_quaternion, quaternion_to_rows, rpy_matrix
from pyflyt_engine.spec import BodySpec, check_identifier

if TYPE_CHECKING:
    from pyflyt_engine.vehicle import Vehicle
    from pyflyt_engine.world import World

Vec3 = tuple[float, float, float]

#: mass [kg] and radius [m] of the tether's pivot link: small against any payload, large
#: enough to keep the articulated body well conditioned
PIVOT_MASS = 1e-3
PIVOT_RADIUS = 0.005


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)


class AttachSpec(_Model):
    """How a payload is held: parent, joint and anchor points."""

    to: Literal["vehicle", "world"] = Field("vehicle", description="parent: the env's vehicle, or the ground frame")
    joint: Literal["fixed", "ball", "tether", "free"] = Field(
        description="fixed (welded), ball (passive spherical joint), tether (string of 'length'), free (no joint)"
    )
    anchor: Vec3 = Field(
        (0.0, 0.0, 0.0),
        description="joint point on the parent [m]: vehicle body frame from its centre of mass, or ground frame",
    )
    payload_anchor: Vec3 = Field((0.0, 0.0, 0.0), description="joint point on the payload, in the payload's frame [m]")
    length: float | None = Field(None, description="tether only: string length [m], > 0")

    @model_validator(mode="after")
    def _tether(self) -> AttachSpec:
        if self.joint == "tether":
            if self.length is None:
                raise ValueError("a tether needs 'length', the string length in metres (> 0)")
            if not self.length > 0:
                raise ValueError(f"tether length must be > 0 m, got {self.length}")
        elif self.length is not None:
            raise ValueError(f"'length' is for joint: tether only (this joint is '{self.joint}'); remove it")
        return self


class PayloadSpec(_Model):
    """One payload: a rigid body (shapes, mass, inertia in SI units) and its attachment."""

    name: str = Field(description="identifier (letters, digits, _ -); names the payload in info and recordings")
    body: BodySpec = Field(description="shapes, mass [kg] and inertia [kg m^2] as for an airframe's body (no urdf)")
    attach: AttachSpec
    position: Vec3 = Field(
        (0.0, 0.0, 0.0), description="payload frame origin relative to the parent at reset [m] (see attach.to)"
    )
    orientation: Vec3 = Field(
        (0.0, 0.0, 0.0), description="payload frame (roll, pitch, yaw) relative to the parent [rad]"
    )
    collide_with_parent: bool = Field(
        False, description="contacts between the payload and the vehicle it hangs from are simulated (and count)"
    )
    ground_contact_fails: bool = Field(
        True, description="the payload touching the ground ends the episode as a crash (as any vehicle contact does)"
    )

    @field_validator("name")
    @classmethod
    def _name(cls, value: str) -> str:
        return check_identifier(value)

    @model_validator(mode="after")
    def _checks(self) -> PayloadSpec:
        if self.body.urdf is not None:
            raise ValueError("payload body.urdf is not supported: describe the payload with shapes")
        if self.attach.joint == "tether":
            distance = exact.norm(self.anchor_to_payload_anchor())
            if distance <= 1e-9:
                raise ValueError(
                    "tethered payload starts with its payload_anchor on the anchor: place it (position) along the string"
                )
            if distance > self.attach.length + 1e-9:  # type: ignore[operator]
                raise ValueError(
                    f"tethered payload starts {distance:.4g} m from its anchor, farther than the tether "
                    f"length {self.attach.length} m: move it closer or lengthen the tether"
                )
            axis = self.anchor_to_payload_anchor() / distance
            lever = self.center_of_mass() - np.asarray(self.attach.payload_anchor, dtype=float)
            offset = np.array(exact.rotate(self.rotation(), lever))
            if exact.norm(offset - exact.dot(offset, axis) * axis) > 1e-6:
                raise ValueError(
                    "a tethered payload's centre of mass must lie on its string's line (from attach.anchor through "
                    "attach.payload_anchor at reset): tie the string at a point above the centre of mass"
                )
        return self

    # ------------------------------------------------------------- geometry

    def mass(self) -> float:
        """Mass [kg]."""
        return float(self.body.total_mass())

    def center_of_mass(self) -> np.ndarray:
        """Centre of mass in the payload's frame [m]."""
        return self.body.mass_center()

    def inertia_matrix(self) -> np.ndarray:
        """Inertia about the centre of mass in the payload's axes [kg m^2] (parts: parallel axes)."""
        return self.body.inertia_matrix()

    def rotation(self) -> np.ndarray:
        """Payload frame -> parent frame rotation at reset."""
        return rpy_matrix(self.orientation)

    def anchor_to_payload_anchor(self) -> np.ndarray:
        """Vector from ``attach.anchor`` to the payload's anchor point at reset, parent frame [m]."""
        point = np.asarray(self.position) + np.array(exact.rotate(self.rotation(), self.attach.payload_anchor))
        return point - np.asarray(self.attach.anchor, dtype=float)

    def farthest_reach(self) -> float:
        """Upper bound of the distance from the parent's origin of any point of the payload at reset [m]."""
        com = np.asarray(self.position) + np.array(exact.rotate(self.rotation(), self.center_of_mass()))
        return exact.norm(com) + _bounding_radius(self)


def _bounding_radius(spec: PayloadSpec) -> float:
    """Radius [m] of a sphere about the centre of mass holding every shape (conservative)."""
    com = spec.center_of_mass()
    radius = 0.0
    for s in spec.body.shapes:
        # ShapeSpec._dimensions has required the dimensions of each shape type: the asserts only narrow
        if s.type == "box":
            assert s.size is not None
            half = 0.5 * math.sqrt(sum(v * v for v in s.size))
        elif s.type == "cylinder":
            assert s.radius is not None and s.length is not None
            half = math.sqrt(s.radius**2 + (0.5 * s.length) ** 2)
        elif s.type == "sphere":
            assert s.radius is not None
            half = float(s.radius)
        else:
            half = 0.0
        radius = max(radius, exact.norm(np.asarray(s.position) - com) + half)
    return radius


# --------------------------------------------------------------------------- URDF


def _fmt(values: Any) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def _link(name: str, spec: PayloadSpec) -> list[str]:
    """A ``<link>`` whose origin is the payload's centre of mass (inertia diagonal, see urdf.py)."""
    from pyflyt_engine.urdf import shape_elements

    inertia = spec.inertia_matrix()
    lines = [
        f'  <link name="{name}">',
        "    <inertial>",
        '      <origin xyz="0 0 0" rpy="0 0 0"/>',
        f'      <mass value="{spec.mass():.9g}"/>',
        (
            f'      <inertia ixx="{inertia[0, 0]:.9g}" ixy="0" ixz="0" iyy="{inertia[1, 1]:.9g}" iyz="0" '
            f'izz="{inertia[2, 2]:.9g}"/>'
        ),
        "    </inertial>",
    ]
    lines += shape_elements(spec.body.shapes, spec.center_of_mass())
    lines.append("  </link>")
    return lines


def generate_payload_urdf(spec: PayloadSpec) -> str:
    """URDF text of a payload: one link ``body``; a tether adds the pivot link ``pivot`` as base.

    Tether: the prismatic joint's axis is the string's direction at reset (anchor to
    ``payload_anchor``); the pivot's frame is aligned with the parent's at reset, the
    payload's frame turned from it by ``orientation``; the joint coordinate is the distance
    of the centre of mass from the anchor along the string.
    """
    lines = ['<?xml version="1.0"?>', f'<robot name="payload_{spec.name}">']
    if spec.attach.joint != "tether":
        lines += _link("body", spec)
    else:
        axis, _q0, upper = tether_geometry(spec)
        r = PIVOT_RADIUS
        pivot_inertia = 0.4 * PIVOT_MASS * r * r
        lines += [
            '  <link name="pivot">',
            "    <inertial>",
            f'      <mass value="{PIVOT_MASS:.9g}"/>',
            (
                f'      <inertia ixx="{pivot_inertia:.9g}" ixy="0" ixz="0" iyy="{pivot_inertia:.9g}" iyz="0" '
                f'izz="{pivot_inertia:.9g}"/>'
            ),
            "    </inertial>",
            "  </link>",
        ]
        lines += _link("body", spec)
        lines += [
            '  <joint name="tether" type="prismatic">',
            '    <parent link="pivot"/>',
            '    <child link="body"/>',
            # the payload's frame turned by its declared orientation; the axis is given in it
            f'    <origin xyz="0 0 0" rpy="{_fmt(spec.orientation)}"/>',
            f'    <axis xyz="{_fmt(exact.rotate_t(spec.rotation(), axis))}"/>',
            f'    <limit lower="0" upper="{upper:.9g}" effort="0" velocity="1000"/>',
            '    <dynamics damping="0" friction="0"/>',
            "  </joint>",
        ]
    lines += ["</robot>", ""]
    return "\n".join(lines)


def tether_geometry(spec: PayloadSpec) -> tuple[np.ndarray, float, float]:
    """(unit axis in the parent frame, joint coordinate at reset, joint upper limit) [m] of a tether.

    The prismatic joint moves the payload's centre of mass along the string's line (anchor
    to ``payload_anchor`` at reset); the payload keeps its orientation relative to that
    line, as a bob on a rigid-while-taut string does.  The centre of mass lies on the line
    (checked by :class:`PayloadSpec`), a fixed ``offset`` beyond ``payload_anchor``, so the
    string length limits the joint coordinate to ``length + offset``.
    """
    rot = spec.rotation()
    string = spec.anchor_to_payload_anchor()
    axis = string / exact.norm(string)
    com = np.asarray(spec.position) + np.array(exact.rotate(rot, spec.center_of_mass()))
    q0 = exact.dot(axis, com - np.asarray(spec.attach.anchor, dtype=float))
    offset = exact.dot(
        axis, exact.rotate(rot, spec.center_of_mass() - np.asarray(spec.attach.payload_anchor, dtype=float))
    )
    return axis, q0, float(spec.attach.length) + offset  # type: ignore[arg-type]


# ------------------------------------------------------------------------ runtime


@dataclass(frozen=True)
class PayloadState:
    """A payload's state, ground frame: centre-of-mass position [m], quaternion (x, y, z, w),
    linear velocity [m/s] and angular velocity [rad/s]."""

    position: np.ndarray
    quaternion: np.ndarray
    lin_vel: np.ndarray
    ang_vel: np.ndarray

    def point(self, local: Any) -> np.ndarray:
        """Ground-frame position of a point given relative to the centre of mass, payload axes [m]."""
        rotation = quaternion_to_rows(self.quaternion.tolist())
        return self.position + np.array(exact.rotate(rotation, [float(v) for v in local]))

    def point_velocity(self, local: Any) -> np.ndarray:
        """Ground-frame velocity of that point [m/s]."""
        rotation = quaternion_to_rows(self.quaternion.tolist())
        r = exact.rotate(rotation, [float(v) for v in local])
        return self.lin_vel + np.array(exact.cross(self.ang_vel.tolist(), r))


class Payload:
    """One payload in a world: its spec, PyBullet body and joint."""

    def __init__(self, spec: PayloadSpec, body_id: int, link: int, constraint: int | None) -> None:
        self.spec = spec
        self.body_id = body_id
        #: link index of the payload's rigid body (-1: the base; 0: behind a tether pivot)
        self.link = link
        self.constraint = constraint
        self.com = spec.center_of_mass()
        self.urdf_text = ""

    def local(self, point: Any) -> np.ndarray:
        """A point of the payload's frame relative to its centre of mass [m]."""
        return np.asarray(point, dtype=float) - self.com


class PayloadSet:
    """The payloads of an env, built in ``world`` around ``vehicle`` (the PyBullet adapter).

    Bodies are tracked by the world's contacts (:meth:`World.add_body`).  Call
    :meth:`place` after every vehicle reset.
    """

    def __init__(self, world: World, vehicle: Vehicle, specs: list[PayloadSpec]) -> None:
        from pyflyt_engine.bullet import pybullet as p

        from pyflyt_engine.urdf import cached_urdf

        self.world = world
        self.vehicle = vehicle
        self.payloads: list[Payload] = []
        self.by_name: dict[str, Payload] = {}
        self._failing: set[str] = set()
        cid = world.client
        for spec in specs:
            parent_pos, parent_quat = self._parent_pose(spec)
            text = generate_payload_urdf(spec)
            path = cached_urdf(text)
            pose_pos, pose_quat = self._spawn_pose(spec, parent_pos, parent_quat)
            static = spec.attach.to == "world" and spec.attach.joint == "fixed"
            body = p.loadURDF(
                str(path),
                basePosition=pose_pos,
                baseOrientation=pose_quat,
                useFixedBase=static,
                flags=p.URDF_USE_INERTIA_FROM_FILE,
                physicsClientId=cid,
            )
            link = -1
            if spec.attach.joint == "tether":
                link = 0
                # a free joint: no motor holding it (PyBullet's default velocity motor would lock it)
                p.setJointMotorControl2(body, 0, p.VELOCITY_CONTROL, targetVelocity=0.0, force=0.0, physicsClientId=cid)
            for index in (-1, 0) if link == 0 else (-1,):
                p.changeDynamics(body, index, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
            payload = Payload(spec, body, link, None)
            payload.urdf_text = text
            payload.constraint = self._joint(spec, body, payload)
            if spec.attach.to == "vehicle" and not spec.collide_with_parent:
                for index in (-1, 0) if link == 0 else (-1,):
                    p.setCollisionFilterPair(vehicle.body_id, body, -1, index, 0, physicsClientId=cid)
            world.add_body(body)
            self.payloads.append(payload)
            if spec.ground_contact_fails and not static:
                self._failing.add(spec.name)
            self.by_name[spec.name] = payload

    # ------------------------------------------------------------ building

    def _parent_pose(self, spec: PayloadSpec | None) -> tuple[np.ndarray, tuple[float, float, float, float]]:
        if spec is None or spec.attach.to == "world":
            return np.zeros(3), (0.0, 0.0, 0.0, 1.0)
        s = self.vehicle.state
        return np.asarray(s.lin_pos, dtype=float), tuple(s.quaternion)  # type: ignore[return-value]

    @staticmethod
    def _spawn_pose(
        spec: PayloadSpec, parent_pos: np.ndarray, parent_quat: tuple[float, float, float, float]
    ) -> tuple[list[float], tuple[float, float, float, float]]:
        """Pose of the PyBullet base: the payload's centre of mass (or the tether pivot)."""
        parent_rot = quaternion_to_rows(parent_quat)
        if spec.attach.joint == "tether":  # the base is the pivot, aligned with the parent
            return list(parent_pos + np.array(exact.rotate(parent_rot, spec.attach.anchor))), parent_quat
        rot = np.array(exact.matmul(parent_rot, spec.rotation()))
        com = (
            parent_pos
            + np.array(exact.rotate(parent_rot, spec.position))
            + np.array(exact.rotate(rot, spec.center_of_mass()))
        )
        return list(com), matrix_to_quaternion(rot)

    def _joint(self, spec: PayloadSpec, body: int, payload: Payload) -> int | None:
        from pyflyt_engine.bullet import pybullet as p

        joint = spec.attach.joint
        if joint == "free" or (spec.attach.to == "world" and joint == "fixed"):
            return None
        cid = self.world.client
        anchor = [float(v) for v in spec.attach.anchor]
        zero = [0.0, 0.0, 0.0]
        child = zero if joint == "tether" else list(payload.local(spec.attach.payload_anchor))
        if spec.attach.to == "world":  # PyBullet: the world is the child (-1), its frame the ground frame
            return p.createConstraint(body, -1, -1, -1, p.JOINT_POINT2POINT, zero, child, anchor, physicsClientId=cid)
        parent = self.vehicle.body_id
        if joint in ("tether", "ball"):  # the tether's pivot, or the payload's anchor point, on the anchor
            return p.createConstraint(
                parent, -1, body, -1, p.JOINT_POINT2POINT, zero, anchor, child, physicsClientId=cid
            )
        # fixed: the payload frame held at its reset pose relative to the parent
        com_offset = exact.rotate(spec.rotation(), spec.center_of_mass())
        com_in_parent = np.asarray(spec.position, dtype=float) + np.array(com_offset)
        return p.createConstraint(
            parent,
            -1,
            body,
            -1,
            p.JOINT_FIXED,
            zero,
            list(com_in_parent),
            [0.0, 0.0, 0.0],
            parentFrameOrientation=matrix_to_quaternion(spec.rotation()),
            physicsClientId=self.world.client,
        )

    # ------------------------------------------------------------ per episode

    def place(self) -> None:
        """Put every payload at its declared pose relative to its parent, moving with it.

        Call after the vehicle has been reset: a payload attached to the vehicle takes the
        vehicle's velocity at its point (v + omega x r), a tether its full length.
        """
        from pyflyt_engine.bullet import pybullet as p

        cid = self.world.client
        s = self.vehicle.state
        v_ground = np.asarray(s.lin_vel_ground, dtype=float)
        w_ground = np.asarray(s.ang_vel_ground, dtype=float)
        for payload in self.payloads:
            spec = payload.spec
            if spec.attach.to == "world" and spec.attach.joint == "fixed":
                continue  # static: never moves
            parent_pos, parent_quat = self._parent_pose(spec)
            position, quaternion = self._spawn_pose(spec, parent_pos, parent_quat)
            if spec.attach.to == "vehicle":
                lin = v_ground + np.cross(w_ground, np.asarray(position) - parent_pos)
                ang = w_ground
            else:
                lin, ang = np.zeros(3), np.zeros(3)
            p.resetBasePositionAndOrientation(payload.body_id, position, quaternion, physicsClientId=cid)
            p.resetBaseVelocity(payload.body_id, list(lin), list(ang), physicsClientId=cid)
            if payload.link == 0:
                _axis, q0, _upper = tether_geometry(spec)
                p.resetJointState(payload.body_id, 0, q0, 0.0, physicsClientId=cid)

    def state(self, name: str | int) -> PayloadState:
        """The current :class:`PayloadState` of a payload, by name or index."""
        from pyflyt_engine.bullet import pybullet as p

        payload = self.payloads[name] if isinstance(name, int) else self.by_name[name]
        cid = self.world.client
        if payload.link < 0:
            pos, quat = p.getBasePositionAndOrientation(payload.body_id, physicsClientId=cid)
            lin, ang = p.getBaseVelocity(payload.body_id, physicsClientId=cid)
        else:
            link = p.getLinkState(
                payload.body_id, payload.link, computeLinkVelocity=1, computeForwardKinematics=1, physicsClientId=cid
            )
            pos, quat, lin, ang = link[0], link[1], link[6], link[7]
        return PayloadState(np.array(pos), np.array(quat), np.array(lin), np.array(ang))

    def ground_failure(self) -> bool:
        """Whether a payload declared ``ground_contact_fails`` touched the ground in the last step."""
        failing = self._failing
        return bool(failing) and any(name in failing for name in self.touched_ground())

    def touched_ground(self) -> list[str]:
        """Names of the payloads that touched the ground during the last world step."""
        world = self.world
        if world.ground_id is None:
            return []
        matrix = world.contact_array
        index = {body: i for i, body in enumerate(world.contact_bodies)}
        g = index[world.ground_id]
        return [pl.spec.name for pl in self.payloads if matrix[g, index[pl.body_id]]]

    def touched(self, a: str, b: str | None = None) -> bool:
        """Whether payload ``a`` touched payload ``b`` (or, with ``b`` None, the vehicle) in the last step."""
        world = self.world
        index = {body: i for i, body in enumerate(world.contact_bodies)}
        other = self.vehicle.body_id if b is None else self.by_name[b].body_id
        return bool(world.contact_array[index[self.by_name[a].body_id], index[other]])

    def __iter__(self) -> Any:
        return iter(self.payloads)

    def __len__(self) -> int:
        return len(self.payloads)


class PayloadSets:
    """Several :class:`PayloadSet` seen as one (every agent's payloads in a multi-agent env):
    iterating gives every payload, :meth:`state` finds one by its (unique) name.  What the
    recorder reads of an env's payloads."""

    def __init__(self, sets: list[PayloadSet]) -> None:
        self.sets = list(sets)
        self._owner = {payload.spec.name: s for s in self.sets for payload in s}

    def state(self, name: str) -> PayloadState:
        """The current :class:`PayloadState` of the payload named ``name``."""
        return self._owner[name].state(name)

    def __iter__(self) -> Any:
        return (payload for s in self.sets for payload in s)

    def __len__(self) -> int:
        return sum(len(s) for s in self.sets)
