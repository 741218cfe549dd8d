"""A setting declared once: a config dataclass's field metadata is its node parameter (pure: no ROS, no io).

A configuration dataclass declares each setting with :func:`setting` (default, description, unit, range,
per-joint and read-only flags). From it

- :func:`declarations` builds the node's parameter declarations (:class:`ParamDecl`, declared to ROS by
  ``nodes.runtime.declare_parameters`` and checked by the CLI's ``--set``), and :func:`per_joint` the
  names each joint may have of its own (``<joint>.<setting>``);
- :func:`from_mapping` builds the config from parameter values, wherever they come from (a node's
  parameters, a params YAML, ``--set``, a bag's recorded settings): ROS types become the field's type
  (a list becomes a tuple, an integer given for a double that double) and a value outside its range is
  refused with one line naming the setting, its unit and its range;
- :func:`check_ranges` refuses a config constructed with a setting outside its range (each config's
  ``__post_init__`` or ``check`` calls it with its own error type): the range is written once, in the
  field, and only cross-field checks (``min_speed <= max_speed``) are written by hand.

A setting whose node parameter is named otherwise says so (``param="alarm_threshold"``); a mutable
default is made by ``default_factory``.

So adding a setting is one line in the dataclass (the idea of ros2_controllers'
``generate_parameter_library``, with the dataclass as the one place):

>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Demo:
...     joint_name: str = "joint_1"  # no metadata: not a parameter
...     wear: float = setting(0.0, description="true wear level", unit="%", range=(0.0, 100.0), per_joint=True)
...     seeds: tuple[float, ...] = setting((1.0, 2.0), description="seeds")
>>> [(d.name, d.default, d.min, d.max) for d in declarations(Demo)]
[('wear', 0.0, 0.0, 100.0), ('seeds', [1.0, 2.0], None, None)]
>>> per_joint(Demo)
('wear',)
>>> from_mapping(Demo, {"wear": 30, "seeds": [3, 4], "unrelated": "x"}, joint_name="joint_2")
Demo(joint_name='joint_2', wear=30.0, seeds=(3.0, 4.0))
>>> from_mapping(Demo, {"wear": 20.0, "joint_2.wear": 40.0}, joint="joint_2").wear
40.0
>>> from_mapping(Demo, {"wear": 300})
Traceback (most recent call last):
...
jointwear_ros.errors.ParameterError: wear=300: outside the declared range [0.0, 100.0] %
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

from .errors import ParameterError

__all__ = ["SETTING", "NodeDeclarations", "ParamDecl", "check_ranges", "declarations", "from_mapping",
           "node_declarations", "per_joint", "setting", "settings_of"]

#: the field-metadata key under which :func:`setting` keeps its :class:`ParamDecl`
SETTING = "jointwear.setting"


@dataclass(frozen=True)
class ParamDecl:
    """A node parameter: default (its type is the parameter's), description, optional numeric range.

    ``dynamic``: any type (a list of regexes, say); the default only says what "unset" is.
    ``unit`` is said in range errors; ``per_joint``: each joint of a robot node may have its own
    value (``<joint>.<name>``, the node-level value its default).

    >>> ParamDecl("warn_threshold", 30.0, "wear of WARN", 0.0, 100.0).check(31)
    31.0
    """

    name: str
    default: Any
    description: str
    min: float | None = None
    max: float | None = None
    #: read at start-up only: a run-time change is refused by rclpy with "parameter is read-only"
    read_only: bool = False
    dynamic: bool = False
    unit: str | None = None
    per_joint: bool = False

    def check(self, value: Any) -> Any:
        """``value`` as this parameter takes it (an integer for a double becomes that double), or a
        :class:`~jointwear_ros.errors.ParameterError` saying why not (a number expected, not finite,
        outside the declared range)."""
        numeric = isinstance(self.default, (int, float)) and not isinstance(self.default, bool)
        if self.dynamic or not numeric:
            return value
        if isinstance(self.default, float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)  # 30 where 30.0 is declared: what everyone types
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (
                isinstance(self.default, float) != isinstance(value, float)):
            kind = "a number" if isinstance(self.default, float) else "an integer"
            raise ParameterError(f"{self.name} is {kind} (default {self.default:g}{self._unit}), not {value!r}")
        if not math.isfinite(float(value)):
            raise ParameterError(f"{self.name}={value:g}: not a finite number")
        if (self.min is not None and value < self.min) or (self.max is not None and value > self.max):
            raise ParameterError(
                f"{self.name}={value:g}: outside the declared range [{self.min}, {self.max}]{self._unit}"
            )
        return value

    @property
    def _unit(self) -> str:
        return f" {self.unit}" if self.unit else ""


def setting(default: Any = dataclasses.MISSING, *, description: str, unit: str | None = None,
            range: tuple[float, float] | None = None, per_joint: bool = False, read_only: bool = False,
            parse: Callable[[Any], Any] | None = None, param_default: Any = None, param: str | None = None,
            default_factory: Callable[[], Any] | None = None) -> Any:
    """A dataclass field that is also a node parameter (see the module docstring).

    Parameters
    ----------
    default
        The field's default; the parameter's too (a tuple is declared as a list), unless ``param_default``.
    description, unit
        What the parameter's descriptor and errors say.
    range
        ``(low, high)``, inclusive, for a number: the node declares it, :func:`from_mapping` refuses a
        parameter value outside it and :func:`check_ranges` a config built outside it.
    per_joint
        Each joint of a robot node may have its own value (``<joint>.<name>``).
    read_only
        Read at start-up only.
    parse
        Turns the parameter's value into the field's (e.g. a comma list string into a tuple of names);
        it raises :class:`~jointwear_ros.errors.ParameterError` on a bad value. Default: by the field's type.
    param_default
        The parameter's default when its type differs from the field's (with ``parse``).
    param
        The node parameter's name when it is not the field's (``alarm_threshold`` for a field ``alarm``).
    default_factory
        Instead of ``default``: makes each instance's default (a mutable one, a ``{}``); the parameter's
        default is what it makes, unless ``param_default``.
    """
    if (default is dataclasses.MISSING) == (default_factory is None):
        raise TypeError("setting() takes a default or a default_factory (one of them)")
    lo, hi = range if range is not None else (None, None)
    made = default_factory() if default_factory is not None else default
    decl_default = param_default if param_default is not None else made
    if isinstance(decl_default, tuple):
        decl_default = list(decl_default)
    decl = ParamDecl(param or "", decl_default, description, lo, hi, read_only=read_only, unit=unit,
                     per_joint=per_joint)
    metadata = {SETTING: decl, SETTING + ".parse": parse}
    if default_factory is not None:
        return dataclasses.field(default_factory=default_factory, metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def settings_of(cls: Any) -> dict[str, ParamDecl]:
    """The settings of config dataclass ``cls`` (or of a config) by field name, in field order, each named
    as its node parameter (the field's name unless :func:`setting`'s ``param``; fields without
    :func:`setting` metadata are not parameters)."""
    return {f.name: dataclasses.replace(f.metadata[SETTING], name=f.metadata[SETTING].name or f.name)
            for f in dataclasses.fields(cls) if SETTING in f.metadata}


def declarations(cls: type) -> tuple[ParamDecl, ...]:
    """The node parameter declarations of config dataclass ``cls``, in field order."""
    return tuple(settings_of(cls).values())


class NodeDeclarations(NamedTuple):
    """A node's parameters (:func:`node_declarations`): what its module exports as ``PARAMETERS``,
    ``LIVE_PARAMETERS`` and ``PER_JOINT``."""

    #: every parameter, in declaration order
    parameters: tuple[ParamDecl, ...]
    #: the names of those that may change at run time (not read-only)
    live: tuple[str, ...]
    #: the names each joint may have of its own (``<joint>.<name>``)
    per_joint: tuple[str, ...]


def node_declarations(config: type, head: tuple[ParamDecl, ...] = (),
                      tail: tuple[ParamDecl, ...] = ()) -> NodeDeclarations:
    """A node's parameters: its own ``head``, the settings of config dataclass ``config`` (:func:`declarations`),
    its own ``tail``; with the live and the per-joint names among them.

    >>> @dataclass(frozen=True)
    ... class Demo:
    ...     wear: float = setting(0.0, description="true wear level", range=(0.0, 100.0), per_joint=True)
    >>> own = ParamDecl("topic", "/wear", "output", read_only=True)
    >>> decls = node_declarations(Demo, head=(own,))
    >>> [d.name for d in decls.parameters], decls.live, decls.per_joint
    (['topic', 'wear'], ('wear',), ('wear',))
    """
    params = (*head, *declarations(config), *tail)
    return NodeDeclarations(params, tuple(d.name for d in params if not d.read_only),
                            tuple(d.name for d in params if d.per_joint))


def per_joint(cls: type) -> tuple[str, ...]:
    """The parameters of ``cls`` each joint may have of its own (``<joint>.<parameter>``)."""
    return tuple(d.name for d in settings_of(cls).values() if d.per_joint)


def from_mapping(cls: type, values: Mapping[str, Any], *, joint: str | None = None, **fixed: Any) -> Any:
    """Config ``cls`` from parameter values ``values`` (parameter name -> value, the field's name unless
    :func:`setting`'s ``param``; names that are not settings are ignored, a setting missing keeps its
    default); ``fixed`` sets fields directly (by field name).

    With ``joint``, a per-joint setting is taken from ``<joint>.<name>`` when present, else from
    ``<name>``. Each value is converted to the field's type and range-checked: a
    :class:`~jointwear_ros.errors.ParameterError` in one line naming the setting (as ``<joint>.<name>``
    when it was the joint's own), its unit and its range.
    """
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs: dict[str, Any] = {}
    for name, decl in settings_of(cls).items():
        if name in fixed:
            continue
        key = decl.name
        if joint is not None and decl.per_joint and f"{joint}.{decl.name}" in values:
            key = f"{joint}.{decl.name}"
        if key not in values or values[key] is None:
            continue
        parse = fields[name].metadata.get(SETTING + ".parse")
        d = dataclasses.replace(decl, name=key)
        kwargs[name] = parse(values[key]) if parse is not None else _coerce(d, hints[name], values[key])
    return cls(**kwargs, **fixed)


def check_ranges(config: Any, error: type[Exception] = ParameterError, what: str = "") -> None:
    """Refuse a config whose settings are outside their declared ranges: the one check of the ranges a
    config's ``__post_init__`` (or ``check``) calls, so a range is written once, in the field's
    :func:`setting`. Raises ``error`` (the config's own error type) in one line naming the setting
    (``what`` before it, e.g. ``"observer setting"``), its value, the range and its unit; a number
    that is not finite is refused too. Only cross-field and semantic checks stay in the config.

    >>> @dataclass(frozen=True)
    ... class Demo:
    ...     wear: float = setting(0.0, description="true wear level", unit="%", range=(0.0, 100.0))
    >>> check_ranges(Demo(wear=101.0), what="demo setting")
    Traceback (most recent call last):
    ...
    jointwear_ros.errors.ParameterError: demo setting wear=101: outside the declared range [0.0, 100.0] %
    """
    prefix = f"{what} " if what else ""
    for name, decl in settings_of(config).items():
        if decl.min is None and decl.max is None:
            continue
        value = getattr(config, name)
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise error(f"{prefix}{decl.name} is a number, not {value!r}")
        v = float(value)
        if not math.isfinite(v):
            raise error(f"{prefix}{decl.name}={v:g}: not a finite number (declared range [{decl.min}, {decl.max}]"
                        f"{decl._unit})")
        if (decl.min is not None and v < decl.min) or (decl.max is not None and v > decl.max):
            raise error(f"{prefix}{decl.name}={value:g}: outside the declared range [{decl.min}, {decl.max}]"
                        f"{decl._unit}")


def _coerce(decl: ParamDecl, hint: Any, value: Any) -> Any:
    """``value`` (a ROS parameter value) as a field of type ``hint`` takes it, range-checked."""
    name = decl.name
    if hint is bool:
        if not isinstance(value, bool):
            raise ParameterError(f"{name} is true or false, not {value!r}")
        return value
    if hint is str:
        if isinstance(value, (list, tuple, dict)):
            raise ParameterError(f"{name} is a string, not {value!r}")
        return str(value)
    if hint in (int, float):
        return decl.check(value)
    if typing.get_origin(hint) is tuple:
        args = typing.get_args(hint)
        if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
            raise ParameterError(f"{name} is a list, not {value!r}")
        items = list(value)
        variadic = len(args) == 2 and args[1] is Ellipsis
        if not variadic and len(items) != len(args):
            shape = "[low, high]" if len(args) == 2 else f"a list of {len(args)} values"
            raise ParameterError(f"{name} must be {shape}, got {items}")
        item_type = args[0]  # a homogeneous tuple: tuple[float, ...] or tuple[float, float]
        out = []
        for v in items:
            if item_type is float and (isinstance(v, bool) or not isinstance(v, (int, float))):
                raise ParameterError(f"{name} is a list of numbers, not {value!r}")
            out.append(item_type(v))
        if item_type is float and not all(math.isfinite(v) for v in out):
            raise ParameterError(f"{name} = {out}: not all finite numbers")
        return tuple(out)
    return value
