"""The ``[machine]`` table shared by the cutting, response and surface tests (SI units)."""

MACHINE = {
    "tool_body": "head",
    "workpiece_body": "slider",
    "spindle_axis_xy": [0.0, 0.0],
    "cutting_plane_z": 0.0,
    "tool_radius": 0.25,
    "workpiece_size": [0.41, 0.41],
    "workpiece_center_xy": [0.0, 0.0],
    "rotation": "cw",
}
