"""A rosbags typestore with ROS 2 Jazzy's types plus ``jointwear_msgs``.

The ``jointwear_msgs`` definitions are read from their ``.msg`` files, found
through :func:`jointwear_ros.resources.resource_dirs` (the source tree's
``msg_defs/msg`` in a checkout, else the ament index and prefixes'
``share/jointwear_msgs/msg``). No ROS runtime is needed.
"""

from __future__ import annotations

import functools
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from ..errors import JointwearError
from ..resources import resource_dirs

__all__ = ["JOINTWEAR_MSG_TYPES", "jointwear_typestore", "msg_definition_dirs", "new_jointwear_typestore"]

JOINTWEAR_MSG_TYPES = ("FrictionObservation", "WearEstimate", "TestCycleStatus", "WearTrend")


def msg_definition_dirs() -> list[Path]:
    return [d / "msg" for d in resource_dirs("jointwear_msgs")]


def new_jointwear_typestore(required: bool = True) -> Typestore:
    """A new Jazzy typestore with ``jointwear_msgs/msg/*`` registered, for a caller that adds types to it.

    ``required=False`` returns the plain Jazzy store when the definitions are not found (the recorder
    then records jointwear topics only once their types are found another way).
    """
    store = get_typestore(Stores.ROS2_JAZZY)
    for d in msg_definition_dirs():
        if all((d / f"{n}.msg").is_file() for n in JOINTWEAR_MSG_TYPES):
            types = {}
            for n in JOINTWEAR_MSG_TYPES:
                types.update(get_types_from_msg((d / f"{n}.msg").read_text(), f"jointwear_msgs/msg/{n}"))
            store.register(types)
            return store
    if not required:
        return store
    raise JointwearError(
        "jointwear_msgs message definitions not found in "
        + ", ".join(str(d) for d in msg_definition_dirs())
        + "; run 'make env' (or build jointwear_msgs with colcon)"
    )


@functools.lru_cache(maxsize=1)
def jointwear_typestore() -> Typestore:
    """The shared (cached) Jazzy typestore with ``jointwear_msgs/msg/*``; do not register types into it."""
    return new_jointwear_typestore()
