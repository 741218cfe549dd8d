"""Shared node plumbing: the ``main`` shape of ros2/examples and typed parameter declaration.

``run_node(MyNode, args)`` does ``rclpy.init``, constructs the node, spins,
handles Ctrl-C, SIGTERM and external shutdown, calls the node's ``on_shutdown``
hook (where motion nodes send their final zero command) while the context is
still valid, destroys the node if it was built, and ends with
``rclpy.try_shutdown()``. rclpy's own signal handlers are not installed: they
would shut the context down before a zero command could be published.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import traceback
from collections.abc import Callable, Iterator, Mapping, MutableMapping, Sequence
from pathlib import Path
from typing import Any

import rclpy
import rclpy.logging
from builtin_interfaces.msg import Time
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos_overriding_options import QoSOverridingOptions
from rclpy.signals import SignalHandlerOptions

from ..contract import seconds_to_stamp_fields
from ..settings import ParamDecl

__all__ = [
    "JOINTS",
    "NODES",
    "ParamDecl",
    "accept_integers_for_doubles",
    "ask_node_parameters",
    "declare_accepting_integers",
    "declare_parameters",
    "loopback_env",
    "message_class",
    "node_parameter",
    "node_parameters",
    "on_parameter_change",
    "overridable_qos",
    "run_node",
    "run_node_refusing",
    "seconds_to_stamp",
    "signals_held",
    "subscribe_reporting_loss",
    "use_prompt_acks",
    "wait_acked",
]


def overridable_qos() -> QoSOverridingOptions:
    """``qos_overriding_options`` for a publisher or subscription: history, depth and reliability can be
    overridden at start-up by the read-only parameters ``qos_overrides.<topic>.<publisher|subscription>.<policy>``
    (e.g. ``qos_overrides./joint_states.subscription.reliability: best_effort`` for a best-effort driver)."""
    return QoSOverridingOptions.with_default_policies()


def seconds_to_stamp(t: float) -> Time:
    """Float seconds -> ``builtin_interfaces/Time`` (the contract's conversion; clamped at 0)."""
    sec, nanosec = seconds_to_stamp_fields(t)
    return Time(sec=sec, nanosec=nanosec)


def loopback_env(domain_id: int | None = None, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """An environment for child ROS processes: DDS on loopback, on ``domain_id``."""
    env = dict(os.environ if base is None else base)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    if domain_id is not None:
        env["ROS_DOMAIN_ID"] = str(domain_id)
    return env


#: The Fast DDS variable naming a default XML profile (rmw_fastrtps_cpp, Fast DDS 2.x as in Jazzy).
FASTDDS_PROFILES_VAR = "FASTRTPS_DEFAULT_PROFILES_FILE"


#: The suite's Fast DDS profiles (``config/dds/``): every process's, and a deep-queue node's (the same writers).
PROMPT_ACKS_PROFILE = "dds/prompt_acks.xml"
DEEP_QUEUES_PROFILE = "dds/deep_reader_queues.xml"


def _own_profile(value: str | None) -> bool:
    """True when ``value`` (the profile variable) names a profile of the user's, not one of the suite's."""
    return bool(value) and Path(str(value)).name not in {Path(PROMPT_ACKS_PROFILE).name, Path(DEEP_QUEUES_PROFILE).name}


def use_prompt_acks(environ: MutableMapping[str, str] | None = None) -> None:
    """Give this process (``environ``: ``os.environ``) ``config/dds/prompt_acks.xml`` before Fast DDS starts,
    unless it names a profile already: reliable writers heartbeat every 50 ms, so
    ``wait_for_all_acked`` (a node's last messages on its way out, ``replay --publish``'s end) returns once the
    readers have the data (about 0.06 s on loopback) instead of after Fast DDS's default 3 s heartbeat."""
    from ..resources import config_path

    env = os.environ if environ is None else environ
    profile = config_path(PROMPT_ACKS_PROFILE)
    # an installation without the file keeps Fast DDS's defaults: a variable naming no file makes every
    # process print Fast DDS's XML parser errors
    if not env.get(FASTDDS_PROFILES_VAR) and profile.is_file():
        env[FASTDDS_PROFILES_VAR] = str(profile)


def deep_queue_env(env: Mapping[str, str]) -> dict[str, str]:
    """``env`` for a node whose subscriptions must queue more than 5000 samples: Fast DDS caps a DataReader
    at 5000 (its ``max_samples``) whatever depth the subscription asks for, so the node gets
    ``config/dds/deep_reader_queues.xml``, a default profile that lifts the readers' resource limits (a depth
    is then the queue; its writers keep the prompt acknowledgements). An environment that names a profile of
    its own keeps it."""
    from ..resources import config_path

    out = dict(env)
    if not _own_profile(out.get(FASTDDS_PROFILES_VAR)):
        out[FASTDDS_PROFILES_VAR] = str(config_path(DEEP_QUEUES_PROFILE))
    return out


def _as_double(p: Parameter, declared: int) -> Parameter:
    """``p`` as a DOUBLE (DOUBLE_ARRAY) when it is an INTEGER (INTEGER_ARRAY) given for a parameter
    declared DOUBLE (DOUBLE_ARRAY): ``30`` where ``30.0`` is meant is what every user types."""
    if declared == ParameterType.PARAMETER_DOUBLE and p.type_ == Parameter.Type.INTEGER:
        return Parameter(p.name, Parameter.Type.DOUBLE, float(p.value))
    if declared == ParameterType.PARAMETER_DOUBLE_ARRAY and p.type_ == Parameter.Type.INTEGER_ARRAY:
        return Parameter(p.name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in p.value])
    return p


def accept_integers_for_doubles(node: Node) -> None:
    """Let ``ros2 param set`` (any set_parameters call) give an integer for a parameter declared as a
    double (an integer array for a double array): it is converted before rclpy checks the type.

    rclpy hands every pre-set-parameters callback the original list and concatenates their
    outputs, so a second callback would send each parameter twice; here the node's pre-set
    callbacks are chained instead (each gets the previous one's list, as a node-level setting
    copied to every joint by ``joints.propagate_node_level``), then the conversion applies to the
    result. Idempotent."""
    if getattr(node, "_jointwear_int_for_double", False):
        return
    node._jointwear_int_for_double = True  # type: ignore[attr-defined]

    def convert(p: Parameter) -> Parameter:
        if not node.has_parameter(p.name):
            return p
        return _as_double(p, node.describe_parameter(p.name).type)

    def chained(parameter_list: list[Parameter]) -> list[Parameter]:
        params = list(parameter_list)
        for callback in node._pre_set_parameters_callbacks:
            params = list(callback(params))
        return [convert(p) for p in params]

    node._call_pre_set_parameters_callback = chained  # type: ignore[method-assign]


def declare_accepting_integers(node: Node, name: str, default: Any, desc: ParameterDescriptor) -> None:
    """``node.declare_parameter`` where an integer override (params file, ``--ros-args -p``) of a
    double parameter is taken as that double, and run-time sets get the same (see
    :func:`accept_integers_for_doubles`)."""
    accept_integers_for_doubles(node)
    overrides = node._parameter_overrides  # rclpy's own: the only way to see a file's value before declaring
    if name in overrides and not isinstance(default, (bool, Parameter.Type)):
        declared = Parameter.Type.from_parameter_value(default).value
        overrides[name] = _as_double(overrides[name], declared)
    node.declare_parameter(name, default, desc)


def declare_parameters(node: Node, decls: Sequence[ParamDecl]) -> dict[str, Any]:
    """Declare each parameter with a descriptor; return name -> current value.

    An integer given for a double (in a params file, ``--ros-args -p`` or later with ``ros2 param
    set``) is taken as that double."""
    out: dict[str, Any] = {}
    for d in decls:
        text = d.description + (" (read at start-up: restart the node to change it)" if d.read_only else "")
        desc = ParameterDescriptor(description=text, read_only=d.read_only, dynamic_typing=d.dynamic)
        if d.dynamic:  # any type (e.g. a list of strings, or none given): declared without type checks
            node.declare_parameter(d.name, d.default, desc)
            out[d.name] = node.get_parameter(d.name).value
            continue
        if d.min is not None and d.max is not None and isinstance(d.default, float):
            desc.floating_point_range = [FloatingPointRange(from_value=float(d.min), to_value=float(d.max))]
        declare_accepting_integers(node, d.name, d.default, desc)
        out[d.name] = node.get_parameter(d.name).value
    return out


#: the jointwear nodes (each ``jointwear_ros.nodes.<name>`` declares its parameters once, in ``PARAMETERS``)
NODES = ("joint_sim", "test_cycle", "friction_observer", "wear_estimator", "wear_trend", "recorder",
         "production_observer", "cycle_on_demand")
#: the nodes that serve a robot: a ``joints`` parameter and per-joint settings ``<joint>.<name>`` (nodes/joints.py)
ROBOT_NODES = ("joint_sim", "test_cycle", "friction_observer", "wear_estimator", "production_observer")
_USE_SIM_TIME = ParamDecl("use_sim_time", False, "rclpy's own: follow /clock")
JOINTS_DESCRIPTION = ("joints served, in order (empty = the single joint joint_name); per-joint settings nest "
                      "under each name")
#: the ``joints`` parameter of a node that serves a robot (declared by ``nodes.joints.declare_joints``)
JOINTS = ParamDecl("joints", [], JOINTS_DESCRIPTION, read_only=True)


def _node_module(node: str) -> Any:
    if node not in NODES:
        raise ValueError(f"unknown node {node!r}; nodes: {', '.join(NODES)}")
    import importlib

    return importlib.import_module(f"jointwear_ros.nodes.{node}")


def node_parameters(node: str) -> dict[str, ParamDecl]:
    """Every node-level parameter ``node`` declares, by name: its ``PARAMETERS``, ``joints`` for a node that
    serves a robot, and rclpy's ``use_sim_time``."""
    decls = {d.name: d for d in _node_module(node).PARAMETERS}
    if node in ROBOT_NODES:
        decls.setdefault("joints", JOINTS)
    decls.setdefault("use_sim_time", _USE_SIM_TIME)
    return decls


def node_parameter(node: str, name: str) -> ParamDecl | None:
    """The declaration of ``node``'s parameter ``name`` (a joint's own ``<joint>.<setting>`` has its setting's),
    or None when the node has no such parameter."""
    from dataclasses import replace

    decls = node_parameters(node)
    if name in decls:
        return decls[name]
    joint, _, setting = name.rpartition(".")
    module = _node_module(node)
    per_joint: tuple[str, ...] = tuple(getattr(module, "PER_JOINT", ()))
    if node in ROBOT_NODES and joint and setting in per_joint and setting in decls:
        return replace(decls[setting], name=name)
    return None


ParameterHandler = Callable[[dict[str, Any]], "str | None"]


def on_parameter_change(node: Node, handler: ParameterHandler, names: Sequence[str]) -> None:
    """Route run-time changes of ``names`` to ``handler``: apply when safe, refuse with a reason.

    ``handler({name: new_value, ...})`` gets the changed parameters among
    ``names`` (others, like rclpy's own ``use_sim_time``, pass through), applies
    them and returns ``None``, or returns the reason for refusing them (or
    raises a ``JointwearError``/``ValueError``, whose message is the reason);
    a refusal leaves every parameter as it was and answers the set_parameters
    call with ``successful=False`` and that reason, and logs it. Parameters
    declared ``read_only`` never get here: rclpy refuses them itself.
    """
    from ..errors import JointwearError

    watched = frozenset(names)
    log = node.get_logger()

    def callback(params: list[Any]) -> SetParametersResult:
        changes = {p.name: p.value for p in params if p.name in watched}
        if not changes:
            return SetParametersResult(successful=True)
        try:
            reason = handler(changes)
        except (JointwearError, ValueError, TypeError) as exc:
            reason = str(exc)
        text = ", ".join(f"{k} := {v!r}" for k, v in changes.items())
        if reason:
            log.warning(f"parameter change refused ({text}): {reason}")
            return SetParametersResult(successful=False, reason=reason)
        log.info(f"parameter change applied: {text}")
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(callback)


def subscribe_reporting_loss(node: Node, msg_type: Any, topic: str, callback: Callable[..., None], qos: Any,
                             on_lost: Callable[[Any], None], **kwargs: Any) -> Any:
    """``node.create_subscription`` with a ``message_lost`` event callback.

    DDS reports samples it dropped before they reached this subscription (a
    reliable writer's history overflowed while the reader was stalled; best
    effort gaps) through that event. An RMW that does not offer it gets a plain
    subscription and one warning: the node works, it just cannot report loss.
    """
    from rclpy.event_handler import SubscriptionEventCallbacks, UnsupportedEventTypeError

    try:
        return node.create_subscription(msg_type, topic, callback, qos,
                                         event_callbacks=SubscriptionEventCallbacks(message_lost=on_lost), **kwargs)
    except UnsupportedEventTypeError:
        node.get_logger().warning(
            f"this RMW does not report lost messages; losses on {topic} cannot be detected", once=True
        )
        return node.create_subscription(msg_type, topic, callback, qos, **kwargs)


def ask_node_parameters(node: Node, asked: dict[str, int], answer: Callable[[str, dict[str, Any]], None],
                        tries: int = 20) -> None:
    """Ask every other node on the graph not asked yet for all its parameters (``~/list_parameters``, then
    ``~/get_parameters``, asynchronously); ``answer(node_name, {name: value})`` gets each answer (the name
    without its leading ``/``). A node whose services are not up yet is asked again at the next call (at most
    ``tries`` times); ``asked`` keeps count between calls (``-1``: asked)."""
    from rcl_interfaces.srv import GetParameters, ListParameters

    from ..io.params import parameter_value

    me = node.get_fully_qualified_name()
    for name, ns in node.get_node_names_and_namespaces():
        fqn = (ns.rstrip("/") + "/" + name) if ns != "/" else "/" + name
        if fqn == me or name.startswith("_") or asked.get(fqn, 0) < 0 or asked.get(fqn, 0) >= tries:
            continue
        asked[fqn] = asked.get(fqn, 0) + 1
        lister = node.create_client(ListParameters, f"{fqn}/list_parameters")
        if not lister.service_is_ready():
            node.destroy_client(lister)
            continue
        asked[fqn] = -1  # asked: not again

        def listed(future: Any, fqn: str = fqn, lister: Any = lister) -> None:
            node.destroy_client(lister)
            try:
                names = list(future.result().result.names)
            except Exception:
                return
            getter = node.create_client(GetParameters, f"{fqn}/get_parameters")

            def got(f2: Any) -> None:
                node.destroy_client(getter)
                try:
                    values = [parameter_value(v) for v in f2.result().values]
                except Exception:
                    return
                answer(fqn.lstrip("/"), {n: v for n, v in zip(names, values, strict=False) if v is not None})

            getter.call_async(GetParameters.Request(names=names)).add_done_callback(got)

        lister.call_async(ListParameters.Request()).add_done_callback(listed)


def message_class(msgtype: str) -> Any:
    """The rosidl Python class of ``pkg/msg/Type`` (what ``rosidl_runtime_py.get_message`` does)."""
    import importlib

    parts = msgtype.split("/")
    if len(parts) != 3:
        raise ValueError(f"message type {msgtype!r} is not of the form pkg/msg/Type")
    module = importlib.import_module(f"{parts[0]}.{parts[1]}")
    return getattr(module, parts[2])


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM ignored inside (a second Ctrl-C must not interrupt closing a file); outside the main
    thread, nothing changes."""
    saved: dict[signal.Signals, Any] = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            saved[sig] = signal.signal(sig, signal.SIG_IGN)
    except ValueError:  # not the main thread
        pass
    try:
        yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)


def wait_acked(publishers: Sequence[Any], seconds: float = 0.5) -> None:
    """On the way out: give reliable subscribers up to ``seconds`` (each publisher) to acknowledge the last
    messages (best effort: a context already shutting down is not an error)."""
    from rclpy.duration import Duration

    for pub in publishers:
        try:
            pub.wait_for_all_acked(Duration(seconds=seconds))
        except Exception:  # pragma: no cover - best effort on the way out
            pass


def context_ok(executor: SingleThreadedExecutor | MultiThreadedExecutor) -> bool:
    """True while the executor's context is valid (not shut down)."""
    return bool(executor.context.ok())


def run_node_refusing(name: str, make: Callable[[], Node], args: Sequence[str] | None = None,
                      events: bool = False) -> int:
    """:func:`run_node` for a node whose constructor checks its start-up settings: a
    :class:`~jointwear_ros.errors.ParameterError` there (an unknown arm, more joints than the arm has, a value
    out of range) is one line on stderr (``<name>: <reason>``) and exit status 2, not a traceback."""
    from ..errors import ParameterError

    refused: list[str] = []

    def factory() -> Node:
        try:
            return make()
        except ParameterError as exc:
            refused.append(str(exc))
            raise ExternalShutdownException from None

    rc = run_node(factory, args, events=events)
    if refused:
        print(f"{name}: {refused[0].removeprefix(name + ': ')}", file=sys.stderr)
        return 2
    return rc


def run_node(
    factory: Callable[[], Node],
    args: Sequence[str] | None = None,
    multithreaded: bool = False,
    events: bool = False,
) -> int:
    """Run one node until Ctrl-C or shutdown; return a process exit code.

    ``events=True`` spins rclpy's C++ ``EventsExecutor`` (several times less
    CPU per message than the Python executors; for high-rate subscribers),
    falling back to the single-threaded executor where it is missing. Its
    ``spin()`` does not return to Python for signals, so it is spun with
    ``spin_once`` in a loop.
    """
    use_prompt_acks()
    rclpy.init(args=None if args is None else list(args), signal_handler_options=SignalHandlerOptions.NO)

    stop: list[int] = []

    def _terminate(signum: int, frame: object) -> None:
        # Only set a flag, checked by the spin_once loops below. Raising KeyboardInterrupt here
        # (what rclpy's own handler amounts to) lands wherever the main thread happens to be,
        # including inside a pybind11 conversion while rclpy takes a message; pybind11 then
        # reports "Unable to convert call argument '0' to Python object" instead, and a clean
        # SIGINT looked like a crash (exit code 1, seen in CI on test_cycle).
        stop.append(signum)

    signal.signal(signal.SIGTERM, _terminate)
    signal.signal(signal.SIGINT, _terminate)
    node: Node | None = None
    rc = 0
    try:
        node = factory()
        events_executor = _events_executor() if events else None
        if events_executor is not None:
            events_executor.add_node(node)
            while rclpy.ok() and not stop:
                events_executor.spin_once(timeout_sec=0.1)
        else:
            executor = MultiThreadedExecutor() if multithreaded else SingleThreadedExecutor()
            executor.add_node(node)
            # spin_once with a wall-clock timeout, not spin(): a node on sim time whose
            # /clock has stopped would block in rcl_wait forever and never run the
            # Python signal handler, so SIGINT/SIGTERM could not stop it.
            while context_ok(executor) and not stop:
                executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as exc:  # construction or a callback failed: say so with the cause, stop cleanly
        name = getattr(factory, "__name__", "node")
        log = node.get_logger() if node is not None else rclpy.logging.get_logger(name)
        log.error(f"fatal: {exc}\n{traceback.format_exc()}")
        rc = 1
    finally:
        if node is not None:
            hook = getattr(node, "on_shutdown", None)
            if callable(hook):
                try:
                    hook()
                except Exception as exc:  # pragma: no cover - best effort on the way out
                    print(f"on_shutdown failed: {exc}\n{traceback.format_exc()}", file=sys.stderr)
            node.destroy_node()
        rclpy.try_shutdown()
    return rc


def _events_executor() -> Any:
    try:
        from rclpy.experimental import EventsExecutor
    except ImportError:  # pragma: no cover - rclpy before Jazzy
        return None
    return EventsExecutor()
