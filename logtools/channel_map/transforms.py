"""Transforms a channel-map entry may name (``transform = "yaw_from_quaternion"``): each turns a
topic's flattened field into the signal's value, reading the columns it declares.

The set is open: a log format whose messages need another transform (a quaternion stored in
another order, a field in another unit) declares it in its own module and adds it with
:func:`register_transform`; a quaternion's component order is a :class:`QuaternionLayout`, so
``yaw_from_quaternion`` over another order is :func:`quaternion_yaw` with that layout.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import polars as pl

__all__ = [
    "ROS_QUATERNION",
    "TRANSFORMS",
    "QuaternionLayout",
    "Transform",
    "quaternion_yaw",
    "register_transform",
]


@dataclass(frozen=True)
class Transform:
    """One transform of a field into a signal's value.

    Attributes:
        name: what a channel map writes (``transform = "NAME"``).
        columns: (field) -> the flattened columns it reads (all must be present).
        value: (frame, field) -> the expression of the signal's value.
        converts_unit: it converts the field's unit itself (a channel map may not also set
            a unit).
    """

    name: str
    columns: Callable[[str], list[str]]
    value: Callable[[pl.DataFrame, str], pl.Expr]
    converts_unit: bool = False


@dataclass(frozen=True)
class QuaternionLayout:
    """Where a quaternion's components are under its field: the suffix of x, y, z and w
    (ROS: ``.x .y .z .w``; an array ``q[4]`` stored w first: ``.1 .2 .3 .0``)."""

    x: str
    y: str
    z: str
    w: str

    def columns(self, fld: str) -> list[str]:
        """The four flattened columns, in the order x, y, z, w."""
        return [f"{fld}.{c}" for c in (self.x, self.y, self.z, self.w)]


ROS_QUATERNION = QuaternionLayout("x", "y", "z", "w")
"""``geometry_msgs/Quaternion``: components named x, y, z, w."""


def quaternion_yaw(name: str, layout: QuaternionLayout) -> Transform:
    """The yaw (rotation about z, rad) of a quaternion laid out as ``layout``."""

    def value(frame: pl.DataFrame, fld: str) -> pl.Expr:
        x, y, z, w = (pl.col(c).cast(pl.Float64) for c in layout.columns(fld))
        return pl.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))

    return Transform(name, layout.columns, value)


def _deg_to_rad(frame: pl.DataFrame, fld: str) -> pl.Expr:
    return pl.col(fld).cast(pl.Float64) * (math.pi / 180)


def _itself(fld: str) -> list[str]:
    return [fld]


TRANSFORMS: dict[str, Transform] = {}
"""Every transform by name: the built-in ones, then those formats register."""


def register_transform(transform: Transform) -> None:
    """Add ``transform`` (a format's own, from its module).

    Raises:
        ValueError: another transform already has that name.
    """
    known = TRANSFORMS.get(transform.name)
    if known is not None and known != transform:
        raise ValueError(f"transform {transform.name!r} is registered already")
    TRANSFORMS[transform.name] = transform


register_transform(quaternion_yaw("yaw_from_quaternion", ROS_QUATERNION))
register_transform(Transform("deg_to_rad", _itself, _deg_to_rad, converts_unit=True))
