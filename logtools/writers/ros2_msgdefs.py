"""ROS 2 message definitions (``ros2msg`` schema text) as rosbag2 stores them: the type's own
fields, then each dependency after a ``====`` separator line and ``MSG: pkg/Type``."""

from __future__ import annotations

__all__ = ["MSGDEFS", "msgdef"]

_SEP = "\n" + "=" * 80 + "\n"

_FIELDS: dict[str, tuple[str, tuple[str, ...]]] = {
    # type: (own field lines, direct dependencies)
    "std_msgs/msg/Float64": ("float64 data", ()),
    "builtin_interfaces/msg/Time": ("int32 sec\nuint32 nanosec", ()),
    "std_msgs/msg/Header": (
        "builtin_interfaces/Time stamp\nstring frame_id",
        ("builtin_interfaces/msg/Time",),
    ),
    "geometry_msgs/msg/Vector3": ("float64 x\nfloat64 y\nfloat64 z", ()),
    "geometry_msgs/msg/Point": ("float64 x\nfloat64 y\nfloat64 z", ()),
    "geometry_msgs/msg/Quaternion": (
        "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
        (),
    ),
    "geometry_msgs/msg/Twist": (
        "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular",
        ("geometry_msgs/msg/Vector3",),
    ),
    "geometry_msgs/msg/Pose": (
        "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation",
        ("geometry_msgs/msg/Point", "geometry_msgs/msg/Quaternion"),
    ),
    "geometry_msgs/msg/PoseWithCovariance": (
        "geometry_msgs/Pose pose\nfloat64[36] covariance",
        ("geometry_msgs/msg/Pose",),
    ),
    "geometry_msgs/msg/TwistWithCovariance": (
        "geometry_msgs/Twist twist\nfloat64[36] covariance",
        ("geometry_msgs/msg/Twist",),
    ),
    "nav_msgs/msg/Odometry": (
        "std_msgs/Header header\nstring child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist",
        (
            "std_msgs/msg/Header",
            "geometry_msgs/msg/PoseWithCovariance",
            "geometry_msgs/msg/TwistWithCovariance",
        ),
    ),
    "sensor_msgs/msg/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort",
        ("std_msgs/msg/Header",),
    ),
}


def _dependencies(name: str) -> list[str]:
    """All dependencies of ``name``, depth first, each once."""
    out: list[str] = []
    for dep in _FIELDS[name][1]:
        for d in [dep, *_dependencies(dep)]:
            if d not in out:
                out.append(d)
    return out


def msgdef(name: str) -> str:
    """The full ``ros2msg`` schema text of ``name`` (e.g. ``nav_msgs/msg/Odometry``).

    Raises:
        KeyError: a type this module does not define.
    """
    parts = [_FIELDS[name][0]]
    for dep in _dependencies(name):
        short = dep.replace("/msg/", "/")
        parts.append(f"MSG: {short}\n{_FIELDS[dep][0]}")
    return _SEP.join(parts)


MSGDEFS: dict[str, str] = {name: msgdef(name) for name in _FIELDS}
"""Schema text by type name."""
