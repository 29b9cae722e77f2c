"""JSON schemas of every telemetry channel.

The ``foxglove.*`` schemas follow Foxglove's published JSON schemas (``foxglove/schemas``,
``schemas/jsonschema``) field for field, so Foxglove opens the files without plug-ins and
draws ``/tf`` and ``/scene`` in its 3-D panel.  The ``pyflyt.*`` schemas describe this
toolkit's own messages; they are strict (``additionalProperties: false``, required
fields), and the tests validate every recorded message against the schema its channel
declares.
"""

from __future__ import annotations

from typing import Any

# ---------------------------------------------------------------- foxglove building blocks

_TIME: dict[str, Any] = {
    "type": "object",
    "title": "time",
    "properties": {
        "sec": {"type": "integer", "minimum": 0},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
    },
}
_DURATION: dict[str, Any] = {
    "type": "object",
    "title": "duration",
    "properties": {
        "sec": {"type": "integer"},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
    },
}


def _described(schema: dict[str, Any], description: str) -> dict[str, Any]:
    return {**schema, "description": description}


def _vector3(description: str) -> dict[str, Any]:
    return {
        "title": "foxglove.Vector3",
        "description": description,
        "type": "object",
        "properties": {
            "x": {"type": "number", "description": "x coordinate length"},
            "y": {"type": "number", "description": "y coordinate length"},
            "z": {"type": "number", "description": "z coordinate length"},
        },
    }


def _quaternion(description: str) -> dict[str, Any]:
    return {
        "title": "foxglove.Quaternion",
        "description": description,
        "type": "object",
        "properties": {
            "x": {"type": "number", "description": "x value"},
            "y": {"type": "number", "description": "y value"},
            "z": {"type": "number", "description": "z value"},
            "w": {"type": "number", "description": "w value"},
        },
    }


def _point3(description: str) -> dict[str, Any]:
    return {
        "title": "foxglove.Point3",
        "description": description,
        "type": "object",
        "properties": {
            "x": {"type": "number", "description": "x coordinate position"},
            "y": {"type": "number", "description": "y coordinate position"},
            "z": {"type": "number", "description": "z coordinate position"},
        },
    }


def _color(description: str) -> dict[str, Any]:
    return {
        "title": "foxglove.Color",
        "description": description,
        "type": "object",
        "properties": {
            "r": {"type": "number", "description": "Red value between 0 and 1"},
            "g": {"type": "number", "description": "Green value between 0 and 1"},
            "b": {"type": "number", "description": "Blue value between 0 and 1"},
            "a": {"type": "number", "description": "Alpha value between 0 and 1"},
        },
    }


def _pose(description: str) -> dict[str, Any]:
    return {
        "title": "foxglove.Pose",
        "description": description,
        "type": "object",
        "properties": {
            "position": _vector3("Point denoting position in 3D space"),
            "orientation": _quaternion("Quaternion denoting orientation in 3D space"),
        },
    }


def _enum(title: str, description: str, values: list[tuple[str, int, str]]) -> dict[str, Any]:
    return {
        "title": title,
        "description": description,
        "oneOf": [{"title": name, "const": value, "description": text} for name, value, text in values],
    }


def _primitive(title: str, description: str, properties: dict[str, Any]) -> dict[str, Any]:
    return {"title": title, "description": description, "type": "object", "properties": properties}


_ARROW = _primitive(
    "foxglove.ArrowPrimitive",
    "A primitive representing an arrow",
    {
        "pose": _pose(
            "Position of the arrow's tail and orientation of the arrow. Identity orientation means the arrow points in the +x direction."
        ),
        "shaft_length": {"type": "number", "description": "Length of the arrow shaft"},
        "shaft_diameter": {"type": "number", "description": "Diameter of the arrow shaft"},
        "head_length": {"type": "number", "description": "Length of the arrow head"},
        "head_diameter": {"type": "number", "description": "Diameter of the arrow head"},
        "color": _color("Color of the arrow"),
    },
)
_CUBE = _primitive(
    "foxglove.CubePrimitive",
    "A primitive representing a cube or rectangular prism",
    {
        "pose": _pose("Position of the center of the cube and orientation of the cube"),
        "size": _vector3("Size of the cube along each axis"),
        "color": _color("Color of the cube"),
    },
)
_SPHERE = _primitive(
    "foxglove.SpherePrimitive",
    "A primitive representing a sphere or ellipsoid",
    {
        "pose": _pose("Position of the center of the sphere and orientation of the sphere"),
        "size": _vector3("Size (diameter) of the sphere along each axis"),
        "color": _color("Color of the sphere"),
    },
)
_CYLINDER = _primitive(
    "foxglove.CylinderPrimitive",
    "A primitive representing a cylinder, elliptic cylinder, or truncated cone",
    {
        "pose": _pose(
            "Position of the center of the cylinder and orientation of the cylinder. The flat face(s) are perpendicular to the z-axis."
        ),
        "size": _vector3("Size of the cylinder's bounding box"),
        "bottom_scale": {
            "type": "number",
            "description": "0-1, ratio of the diameter of the cylinder's bottom face (min z) to the bottom of the bounding box",
        },
        "top_scale": {
            "type": "number",
            "description": "0-1, ratio of the diameter of the cylinder's top face (max z) to the top of the bounding box",
        },
        "color": _color("Color of the cylinder"),
    },
)
_LINE = _primitive(
    "foxglove.LinePrimitive",
    "A primitive representing a series of points connected by lines",
    {
        "type": _enum(
            "foxglove.LineType",
            "Drawing primitive to use for lines",
            [
                ("LINE_STRIP", 0, "Connected line segments: 0-1, 1-2, ..., (n-1)-n"),
                ("LINE_LOOP", 1, "Closed polygon: 0-1, 1-2, ..., (n-1)-n, n-0"),
                ("LINE_LIST", 2, "Individual line segments: 0-1, 2-3, 4-5, ..."),
            ],
        ),
        "pose": _pose("Origin of lines relative to reference frame"),
        "thickness": {"type": "number", "minimum": 0, "description": "Line thickness"},
        "scale_invariant": {
            "type": "boolean",
            "description": "Indicates whether `thickness` is a fixed size in screen pixels (true), or specified in world coordinates and scales with distance from the camera (false)",
        },
        "points": {
            "type": "array",
            "items": _point3("A point representing a position in 3D space"),
            "description": "Points along the line",
        },
        "color": _color("Solid color to use for the whole line. One of `color` or `colors` must be provided."),
        "colors": {
            "type": "array",
            "items": _color("A color in RGBA format"),
            "description": "Per-point colors (if specified, must have the same length as `points`). One of `color` or `colors` must be provided.",
        },
        "indices": {
            "type": "array",
            "items": {"type": "integer", "minimum": 0},
            "description": "Indices into the `points` and `colors` attribute arrays, which can be used to avoid duplicating attribute data.",
        },
    },
)
_TRIANGLES = _primitive(
    "foxglove.TriangleListPrimitive",
    "A primitive representing a set of triangles or a surface tiled by triangles",
    {
        "pose": _pose("Origin of triangles relative to reference frame"),
        "points": {
            "type": "array",
            "items": _point3("A point representing a position in 3D space"),
            "description": "Vertices to use for triangles, interpreted as a list of triples (0-1-2, 3-4-5, ...)",
        },
        "color": _color("Solid color to use for the whole shape. One of `color` or `colors` must be provided."),
        "colors": {
            "type": "array",
            "items": _color("A color in RGBA format"),
            "description": "Per-vertex colors (if specified, must have the same length as `points`). One of `color` or `colors` must be provided.",
        },
        "indices": {
            "type": "array",
            "items": {"type": "integer", "minimum": 0},
            "description": "Indices into the `points` and `colors` attribute arrays, which can be used to avoid duplicating attribute data.",
        },
    },
)
_TEXT = _primitive(
    "foxglove.TextPrimitive",
    "A primitive representing a text label",
    {
        "pose": _pose(
            "Position of the center of the text box and orientation of the text. Identity orientation means the text is oriented in the xy-plane and flows from -x to +x."
        ),
        "billboard": {
            "type": "boolean",
            "description": "Whether the text should respect `pose.orientation` (false) or always face the camera (true)",
        },
        "font_size": {"type": "number", "description": "Font size (height of one line of text)"},
        "scale_invariant": {
            "type": "boolean",
            "description": "Indicates whether `font_size` is a fixed size in screen pixels (true), or specified in world coordinates and scales with distance from the camera (false)",
        },
        "color": _color("Color of the text"),
        "text": {"type": "string", "description": "Text"},
    },
)
_MODEL = _primitive(
    "foxglove.ModelPrimitive",
    "A primitive representing a 3D model file loaded from an external URL or embedded data",
    {
        "pose": _pose("Origin of model relative to reference frame"),
        "scale": _vector3("Scale factor to apply to the model along each axis"),
        "color": _color("Solid color to use for the whole model if `override_color` is true."),
        "override_color": {
            "type": "boolean",
            "description": "Whether to use the color specified in `color` instead of any materials embedded in the original model.",
        },
        "url": {
            "type": "string",
            "description": "URL pointing to model file. One of `url` or `data` should be provided.",
        },
        "media_type": {
            "type": "string",
            "description": "[Media type](https://developer.mozilla.org/en-US/docs/Web/HTTP/Basics_of_HTTP/MIME_types) of embedded model (e.g. `model/gltf-binary`). Required if `data` is provided instead of `url`. Overrides the inferred media type if `url` is provided.",
        },
        "data": {
            "type": "string",
            "contentEncoding": "base64",
            "description": "Embedded model. One of `url` or `data` should be provided. If `data` is provided, `media_type` must be set to indicate the type of the data.",
        },
    },
)

# --------------------------------------------------------------------- foxglove messages

FRAME_TRANSFORM: dict[str, Any] = {
    "title": "foxglove.FrameTransform",
    "description": "A transform between two reference frames in 3D space",
    "$comment": "Follows https://github.com/foxglove/schemas (schemas/jsonschema/FrameTransform.json)",
    "type": "object",
    "properties": {
        "timestamp": _described(_TIME, "Timestamp of transform"),
        "parent_frame_id": {"type": "string", "description": "Name of the parent frame"},
        "child_frame_id": {"type": "string", "description": "Name of the child frame"},
        "translation": _vector3("Translation component of the transform"),
        "rotation": _quaternion("Rotation component of the transform"),
    },
}

SCENE_UPDATE: dict[str, Any] = {
    "title": "foxglove.SceneUpdate",
    "description": "An update to the entities displayed in a 3D scene",
    "$comment": "Follows https://github.com/foxglove/schemas (schemas/jsonschema/SceneUpdate.json)",
    "type": "object",
    "properties": {
        "deletions": {
            "type": "array",
            "items": {
                "title": "foxglove.SceneEntityDeletion",
                "description": "Command to remove previously published entities",
                "type": "object",
                "properties": {
                    "timestamp": _described(
                        _TIME,
                        "Timestamp of the deletion. Only matching entities earlier than this timestamp will be deleted.",
                    ),
                    "type": _enum(
                        "foxglove.SceneEntityDeletionType",
                        "An enumeration indicating which entities should match a SceneEntityDeletion command",
                        [
                            (
                                "MATCHING_ID",
                                0,
                                "Delete the existing entity on the same topic that has the provided `id`",
                            ),
                            ("ALL", 1, "Delete all existing entities on the same topic"),
                        ],
                    ),
                    "id": {"type": "string", "description": "Identifier which must match if `type` is `MATCHING_ID`."},
                },
            },
            "description": "Scene entities to delete",
        },
        "entities": {
            "type": "array",
            "items": {
                "title": "foxglove.SceneEntity",
                "description": "A visual element in a 3D scene. An entity may be composed of multiple primitives which all share the same frame of reference.",
                "type": "object",
                "properties": {
                    "timestamp": _described(_TIME, "Timestamp of the entity"),
                    "frame_id": {"type": "string", "description": "Frame of reference"},
                    "id": {
                        "type": "string",
                        "description": "Identifier for the entity. A entity will replace any prior entity on the same topic with the same `id`.",
                    },
                    "lifetime": _described(
                        _DURATION,
                        "Length of time (relative to `timestamp`) after which the entity should be automatically removed. Zero value indicates the entity should remain visible until it is replaced or deleted.",
                    ),
                    "frame_locked": {
                        "type": "boolean",
                        "description": "Whether the entity should keep its location in the fixed frame (false) or follow the frame specified in `frame_id` as it moves relative to the fixed frame (true)",
                    },
                    "metadata": {
                        "type": "array",
                        "items": {
                            "title": "foxglove.KeyValuePair",
                            "description": "A key with its associated value",
                            "type": "object",
                            "properties": {
                                "key": {"type": "string", "description": "Key"},
                                "value": {"type": "string", "description": "Value"},
                            },
                        },
                        "description": "Additional user-provided metadata associated with the entity. Keys must be unique.",
                    },
                    "arrows": {"type": "array", "items": _ARROW, "description": "Arrow primitives"},
                    "cubes": {"type": "array", "items": _CUBE, "description": "Cube primitives"},
                    "spheres": {"type": "array", "items": _SPHERE, "description": "Sphere primitives"},
                    "cylinders": {"type": "array", "items": _CYLINDER, "description": "Cylinder primitives"},
                    "lines": {"type": "array", "items": _LINE, "description": "Line primitives"},
                    "triangles": {"type": "array", "items": _TRIANGLES, "description": "Triangle list primitives"},
                    "texts": {"type": "array", "items": _TEXT, "description": "Text primitives"},
                    "models": {"type": "array", "items": _MODEL, "description": "Model primitives"},
                },
            },
            "description": "Scene entities to add or replace",
        },
    },
}

COMPRESSED_IMAGE: dict[str, Any] = {
    "title": "foxglove.CompressedImage",
    "description": "A compressed image",
    "$comment": "Follows https://github.com/foxglove/schemas (schemas/jsonschema/CompressedImage.json)",
    "type": "object",
    "properties": {
        "timestamp": _described(_TIME, "Timestamp of image"),
        "frame_id": {
            "type": "string",
            "description": "Frame of reference for the image. The origin of the frame is the optical center of the camera. +x points to the right in the image, +y points down, and +z points into the plane of the image.",
        },
        "data": {"type": "string", "contentEncoding": "base64", "description": "Compressed image data"},
        "format": {
            "type": "string",
            "description": "Image format\n\nSupported values: image media types supported by Chrome, such as `webp`, `jpeg`, `png`",
        },
    },
}

POINT_CLOUD: dict[str, Any] = {
    "title": "foxglove.PointCloud",
    "description": "A collection of N-dimensional points, which may contain additional fields with information like normals, intensity, etc.",
    "$comment": "Follows https://github.com/foxglove/schemas (schemas/jsonschema/PointCloud.json)",
    "type": "object",
    "properties": {
        "timestamp": _described(_TIME, "Timestamp of point cloud"),
        "frame_id": {"type": "string", "description": "Frame of reference"},
        "pose": _pose("The origin of the point cloud relative to the frame of reference"),
        "point_stride": {
            "type": "integer",
            "minimum": 0,
            "description": "Number of bytes between points in the `data`",
        },
        "fields": {
            "type": "array",
            "items": {
                "title": "foxglove.PackedElementField",
                "description": "A field present within each element in a byte array of packed elements.",
                "type": "object",
                "properties": {
                    "name": {"type": "string", "description": "Name of the field"},
                    "offset": {
                        "type": "integer",
                        "minimum": 0,
                        "description": "Byte offset from start of data buffer",
                    },
                    "type": _enum(
                        "foxglove.NumericType",
                        "Type of data in the field. Integers are stored using little-endian byte order.",
                        [
                            ("UNKNOWN", 0, "Unknown type"),
                            ("UINT8", 1, "Unsigned 8-bit integer"),
                            ("INT8", 2, "Signed 8-bit integer"),
                            ("UINT16", 3, "Unsigned 16-bit integer"),
                            ("INT16", 4, "Signed 16-bit integer"),
                            ("UINT32", 5, "Unsigned 32-bit integer"),
                            ("INT32", 6, "Signed 32-bit integer"),
                            ("FLOAT32", 7, "32-bit floating-point number"),
                            ("FLOAT64", 8, "64-bit floating-point number"),
                        ],
                    ),
                },
            },
            "description": "Fields in `data`. At least 2 coordinate fields from `x`, `y`, and `z` are required for each point's position; `red`, `green`, `blue`, and `alpha` are optional for customizing each point's color.",
        },
        "data": {
            "type": "string",
            "contentEncoding": "base64",
            "description": "Point data, interpreted using `fields`",
        },
    },
}

# ------------------------------------------------------------------------ pyflyt messages

_STAMP = {**_TIME, "required": ["sec", "nsec"], "additionalProperties": False}


def _vec(n: int | None, description: str) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "array", "items": {"type": ["number", "null"]}, "description": description}
    if n is not None:
        schema.update(minItems=n, maxItems=n)
    return schema


def _strict(title: str, description: str, properties: dict[str, Any]) -> dict[str, Any]:
    return {
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        "required": list(properties),
        "additionalProperties": False,
    }


_COMMON = {
    "timestamp": _described(_STAMP, "simulation time since the episode's reset"),
    "step": {"type": "integer", "minimum": 0, "description": "agent steps since the reset (0 = the reset itself)"},
    "time": {"type": "number", "minimum": 0, "description": "simulation time since the reset [s]"},
}

VEHICLE_STATE = _strict(
    "pyflyt.VehicleState",
    "Full state of one vehicle after a reset or an agent step (pyflyt_engine.state.KinematicState + aux state)",
    {
        **_COMMON,
        "lin_pos": _vec(3, "position (x, y, z) [m], ground frame (ENU)"),
        "lin_vel": _vec(3, "linear velocity (u, v, w) [m/s], body frame"),
        "lin_vel_ground": _vec(3, "linear velocity (vx, vy, vz) [m/s], ground frame"),
        "ang_pos": _vec(3, "attitude as Euler angles (roll, pitch, yaw) [rad]"),
        "quaternion": _vec(4, "attitude quaternion (x, y, z, w), body-to-ground"),
        "ang_vel": _vec(3, "angular velocity (p, q, r) [rad/s], body frame"),
        "ang_vel_ground": _vec(3, "angular velocity [rad/s], ground frame"),
        "aux": _vec(
            None,
            "auxiliary state (pyflyt_engine.vehicle.Vehicle.aux_state): motor throttles, flap deflections, booster fuel/duty/ignition, gimbal angles",
        ),
        "setpoint": _vec(None, "setpoint of the active flight mode"),
        "mode": {"type": "string", "description": "active flight mode"},
        "collision": {"type": "boolean", "description": "the vehicle touched something during the step"},
    },
)

WIND = _strict(
    "pyflyt.Wind",
    "The wind at one vehicle after a reset or an agent step (pyflyt_engine.atmosphere; recorded when the world has wind)",
    {
        **_COMMON,
        "velocity": _vec(3, "wind velocity (x, y, z) [m/s] at the vehicle, ground frame (ENU)"),
        "rotary": _vec(3, "rotary gust (p, q, r) [rad/s] at the vehicle, ground frame"),
        "air_velocity": _vec(3, "the vehicle's velocity through the air (u, v, w) [m/s], body frame"),
        "air_rates": _vec(3, "the vehicle's angular velocity relative to the air (p, q, r) [rad/s], body frame"),
    },
)

SENSORS = _strict(
    "pyflyt.Sensors",
    "The noisy sensors' readings of one vehicle after a reset or an agent step (pyflyt_engine.components.sensors; "
    "recorded when the airframe has a 'sensors' section)",
    {
        **_COMMON,
        "values": _vec(
            None,
            "the readings, flat, in the channel's 'layout' order (name:size): gyro (p, q, r) [rad/s] and accel "
            "(specific force, x, y, z) [m/s^2] body frame, position (x, y, z) [m] ground frame, position_valid "
            "(0/1), altitude [m]",
        ),
    },
)

ESTIMATE = _strict(
    "pyflyt.Estimate",
    "The flight controller's state estimate of one vehicle after a reset or an agent step "
    "(pyflyt_engine.components.estimator; recorded when the env's sensors.estimator is not none)",
    {
        **_COMMON,
        "quaternion": _vec(4, "estimated attitude (x, y, z, w), body to ground"),
        "ang_pos": _vec(3, "estimated (roll, pitch, yaw) [rad]"),
        "lin_vel_ground": _vec(3, "estimated velocity (x, y, z) [m/s], ground frame (ENU)"),
        "lin_pos": _vec(3, "estimated position (x, y, z) [m], ground frame (ENU)"),
        "gyro_bias": _vec(3, "estimated gyro bias (p, q, r) [rad/s], body frame"),
    },
)

ACTION = _strict(
    "pyflyt.Action",
    "The agent's action for one step; 'applied' (clipped to the action bounds) is what the vehicle received and what re-simulation replays",
    {
        **_COMMON,
        "action": {
            "type": ["array", "null"],
            "items": {"type": ["number", "null"]},
            "description": "the action as given to env.step (null if not numeric)",
        },
        "applied": _vec(None, "the action after clipping: the setpoint sent to the vehicle's flight mode"),
    },
)

REWARD = _strict(
    "pyflyt.Reward",
    "Reward of one agent step with its per-term breakdown (info['reward_terms'], summing to the reward)",
    {
        **_COMMON,
        "reward": {"type": ["number", "null"], "description": "the step's reward"},
        "return": {"type": ["number", "null"], "description": "sum of the rewards since the reset"},
        "terms": {
            "type": "object",
            "additionalProperties": {"type": ["number", "null"]},
            "description": "weighted reward terms by entry name",
        },
    },
)

EPISODE_EVENT = _strict(
    "pyflyt.EpisodeEvent",
    "Episode boundaries: 'reset' opens the episode, 'end' closes it (terminated or truncated), "
    "'stopped' marks a recording stopped before the episode ended (reset or close mid-episode)",
    {
        **_COMMON,
        "event": {"enum": ["reset", "end", "stopped"]},
        "seed": {"type": ["integer", "null"], "description": "seed given to reset (null: the RNG streams continued)"},
        "terminated": {"type": "boolean"},
        "truncated": {"type": "boolean"},
        "reason": {
            "enum": ["", "crash", "collision", "out_of_bounds", "failed", "complete", "time_limit", "stopped"],
            "description": "why the episode ended ('' at reset)",
        },
        "success": {"type": "boolean", "description": "info['success'] at the last step"},
        "return": {"type": ["number", "null"], "description": "sum of the rewards so far"},
        "length": {"type": "integer", "minimum": 0, "description": "agent steps so far"},
        "info": {
            "type": "object",
            "additionalProperties": {"type": ["number", "string", "boolean", "null"]},
            "description": "the scalar entries of the step's info dict",
        },
    },
)
# optional (recordings made before it lack it): the task's success measures of the episode,
# info['measures'] of its last step (pyflyt_engine.envs.tasks.measures), on 'end' events
EPISODE_EVENT["properties"]["measures"] = {
    "type": "object",
    "additionalProperties": {"type": ["number", "null"]},
    "description": "the task's success measures of the episode (NaN as null; 'end' events only)",
}

#: schema name -> schema, for every channel kind a recording uses
ALL: dict[str, dict[str, Any]] = {
    s["title"]: s
    for s in (
        FRAME_TRANSFORM,
        SCENE_UPDATE,
        COMPRESSED_IMAGE,
        POINT_CLOUD,
        VEHICLE_STATE,
        WIND,
        SENSORS,
        ESTIMATE,
        ACTION,
        REWARD,
        EPISODE_EVENT,
    )
}
