"""``joint_sim``: a simulated robot (N joints) behind ros2_control conventions.

Simulates the joints of its ``joints`` parameter (empty: the one joint
``joint_name``), each with its own friction parameter set, wear, temperature,
gravity, noise seed, initial position and velocity loop (``<joint>.<setting>``,
e.g. ``joint_3.wear``; the node-level value is the default, see docs/robot.md).
Subscribes the velocity command of a JointGroupVelocityController
(``std_msgs/Float64MultiArray``, ``data[i]`` = velocity of ``joints[i]``, rad/s;
a command of the wrong length or with a non-finite value is ignored and
counted), publishes one ``/joint_states`` with every joint (position rad,
velocity rad/s, effort N·m; joint side) at ``publish_rate``, the joint
temperatures when ``publish_temperature`` is set (on ``/joint_temperature``,
one ``sensor_msgs/Temperature`` per joint per period, ``header.frame_id`` = the
joint's name; a consumer matches its joint by frame_id) and ``/clock`` when
``publish_clock`` is set. The dynamics are :class:`jointwear_ros.sim.RobotSim`
(one :class:`~jointwear_ros.sim.JointSim` per joint, one integration step per
published sample), or with ``arm`` (``ur5``, ``panda``) a real arm,
:class:`jointwear_ros.sim.ArmSim`: Pinocchio's rigid-body dynamics of its URDF
(coupled joints, gravity of the whole configuration and of ``payload`` kg at
the flange, the URDF's limits), integrated at ``physics_rate`` (each published
sample's step split into sub-steps of at most ``1 / physics_rate``); the i-th
name of ``joints`` drives the arm's i-th joint, the arm's other joints are
locked at its test pose. On an arm each joint's ``gear_ratio``,
``torque_scale``, ``initial_position``, ``kp``, ``ki`` and ``torque_limit``
default to the arm's values for that joint (``jointwear_ros.sim.arms``:
``ArmJoint.sim_defaults``) instead of the node-level ones; a joint's own
``<joint>.<setting>`` still wins. ``inertia``, ``gravity_torque`` and
``gravity_angle`` have no effect there (the arm's are the URDF's). docs/robot.md,
"A real arm".

Time: with ``publish_clock`` the simulator is the graph's clock source and
advances at wall time × ``real_time_factor`` (stamps and ``/clock`` are sim
time, starting at the wall-clock time of start-up); without it, it follows the
node clock (``use_sim_time`` honoured) and ``real_time_factor`` is ignored.
**Lockstep** (``lockstep``, with ``publish_clock``): while a controller streams
velocity commands, sim time runs at most ``lockstep_lead`` ahead of the newest
one, so a controller starved of CPU on a loaded machine slows the clock instead
of falling behind it (its commands would act late in sim time and bend the
constant-speed sweeps); when no command came for ``lockstep_grace`` wall
seconds the controller counts as gone and the clock runs free again
(``command_timeout`` then brings the joints to rest). After a command of zero for
every joint the controller counts as gone after ``lockstep_rest_grace`` (0.5 s) of silence: test_cycle
sends one zero at DONE and stops, and the joint states must keep coming for its next request. Zeros
streamed (a settle between sweeps) hold the clock as any command does: a clock that ran on while the
first command of the next sweep waited in the queue had the arm stand 0.3 s of sim time into a sweep
whose reference had started, and the sweep's end fell inside its window. ``lockstep_holds`` in the
diagnostics counts the ticks the clock waited.

Unlike a real forward command controller, which holds the last command forever,
the simulator brings every joint to rest when no command has arrived for
``command_timeout`` seconds (sim time), so a crashed client never leaves the
simulated joints running into their limits.

Run-time parameters: the physical settings (``wear``, ``temperature``,
gravity, hidden effects, gains, noise, ``max_velocity``, ...) and ``command_timeout``,
``real_time_factor``, ``max_lag``, ``temperature_rate`` apply at once
(``ros2 param set /joint_sim joint_3.wear 40.0``: the next sample of joint_3
has the new friction; a node-level ``wear`` sets every joint's, and their
``<joint>.wear`` parameters with it); an invalid value is refused with the
reason. ``payload`` (kg, with an arm) applies at once too: the arm sags until
its drives catch it. The robot's identity and wiring (``joint_name``, ``joints``,
``arm``, ``physics_rate``, topics, ``gear_ratio``, ``torque_scale``, ``params``,
``seed``, ``publish_*``, ``initial_position``, ``tick_period``) are read at
start-up only (read-only parameters). A bad start-up setting (an unknown arm,
more joints than the arm has, a value out of range) is one line on stderr and
exit status 2. Each joint's noise seed defaults to ``seed`` + its index in
``joints``, so the joints' noise is independent.

Diagnostics: ``joint_sim: <joint>`` on ``/diagnostics`` per joint (OK; WARN
while bad velocity commands arrive), key/values wear, temperature, sim_time,
samples_published, bad_commands.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64MultiArray

from ..contract import DiagnosticLevel
from ..errors import ParameterError
from ..settings import declarations, from_mapping, node_declarations
from ..sim import JointSimConfig, RobotSim, arm_spec, parse_effects
from ..sim.arms import ARM_DEFAULTS, ARMS
from .diagnostics import Status, Updater
from .joints import declare_robot, propagate_node_level
from .runtime import ParamDecl, on_parameter_change, overridable_qos, run_node_refusing, seconds_to_stamp

if TYPE_CHECKING:
    from ..sim import ArmSim

__all__ = ["LIVE_PARAMETERS", "PARAMETERS", "PER_JOINT", "JointSimNode", "joint_config", "main", "parse_effects"]

#: The node's own settings (each joint's simulation settings are JointSimConfig's fields, declared there)
_NODE: tuple[ParamDecl, ...] = (
    ParamDecl("joint_name", "joint_1", "name of the simulated joint in /joint_states when joints is empty",
              read_only=True),
    ParamDecl("joints", [], "the simulated joints, in /joint_states and velocity-command order (empty: joint_name)",
              read_only=True),
    ParamDecl("command_topic", "/velocity_controller/commands", "velocity command topic (Float64MultiArray)", read_only=True),
    ParamDecl("publish_rate", 500.0, "JointState rate = integration rate, Hz (sim time)", 50.0, 20000.0, read_only=True,
              unit="Hz"),
    ParamDecl("publish_temperature", True, "publish /joint_temperature (one message per joint, frame_id = joint)",
              read_only=True),
    ParamDecl("temperature_rate", 10.0, "temperature publish rate, Hz (sim time)", 0.1, 1000.0, unit="Hz"),
    ParamDecl("publish_clock", False, "be the clock source: publish /clock, step on wall time × real_time_factor", read_only=True),
    ParamDecl("real_time_factor", 1.0, "sim seconds per wall second (with publish_clock)", 0.01, 100.0),
    ParamDecl("command_timeout", 0.5, "sim s without a command after which the sim decelerates to 0", 0.0, 1e6,
              unit="s"),
    ParamDecl("max_velocity", 3.0, "largest accepted |command|, joint rad/s (larger ones are clamped)", 0.0, 1e3,
              unit="rad/s", per_joint=True),
    ParamDecl("seed", 0, "seed of the noise generator (joint i of joints: seed + i unless <joint>.seed is given)",
              read_only=True, per_joint=True),
    ParamDecl("tick_period", 0.005, "wall-clock period of the stepping timer, s", 1e-4, 1.0, read_only=True, unit="s"),
    ParamDecl("max_lag", 0.1, "largest sim-time backlog stepped in one tick, s (beyond: the sim slows)", 1e-3, 10.0,
              unit="s"),
    ParamDecl("lockstep", True, "with publish_clock: while a controller streams velocity commands, sim time runs at "
              "most lockstep_lead ahead of its newest command (a starved controller slows the clock, it does not "
              "fall behind it)"),
    ParamDecl("lockstep_lead", 0.05, "how far sim time may run ahead of the newest velocity command, s (sim)",
              1e-3, 10.0, unit="s"),
    ParamDecl("lockstep_grace", 5.0, "wall s without a command after which the controller counts as gone and the "
              "clock runs free again (command_timeout then stops the joints)", 0.01, 60.0, unit="s"),
    ParamDecl("lockstep_rest_grace", 0.5, "the same after a command of zero for every joint (a controller's stop): "
              "wall s without a command after which the clock runs free", 0.01, 60.0, unit="s"),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications (wall time)", 0.01, 60.0,
              read_only=True, unit="s"),
    ParamDecl("arm", "", "simulated arm: '' (independent joints) or " + ", ".join(ARMS) + "; the i-th of joints "
              "drives the arm's i-th joint", read_only=True),
    ParamDecl("payload", 0.0, "payload at the arm's flange, kg (with arm)", 0.0, 20.0, unit="kg"),
    ParamDecl("physics_rate", 1000.0, "integration rate of the arm's dynamics, Hz (with arm; at least "
              "publish_rate)", 100.0, 100000.0, read_only=True, unit="Hz"),
)
#: Parameters of the node (defaults as in ``config/joint_sim.yaml``): its own and :class:`JointSimConfig`'s
#: the parameters that can change at run time (the per-joint ones, ``<joint>.<setting>``, too); the settings
#: each joint has of its own (``<joint>.<setting>``; default: the node-level value)
PARAMETERS, LIVE_PARAMETERS, PER_JOINT = node_declarations(JointSimConfig, _NODE)
_DECLS = {d.name: d for d in PARAMETERS}
#: JointSimConfig fields that can change on a running simulation
_SIM_LIVE = frozenset(d.name for d in declarations(JointSimConfig) if not d.read_only)

_RELIABLE_1000 = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
_RELIABLE_10 = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


def joint_config(values: dict[str, Any]) -> JointSimConfig:
    """A joint's :class:`JointSimConfig` from its parameter values (name -> value)."""
    return from_mapping(JointSimConfig, values)


def per_joint_defaults(params: Mapping[str, Any], joints: Sequence[str]) -> dict[str, list[Any]]:
    """Each joint's own default of the settings that differ per joint (the defaults of ``<joint>.<setting>``):
    its noise seed (``seed`` + its index), and with an ``arm`` the arm's :data:`~jointwear_ros.sim.arms.ARM_DEFAULTS`
    for the joint it drives (its gear, torque scale, test pose, loop gains and effort limit) in place of the
    node-level values. A :class:`ParameterError` (one line) for an unknown arm or more joints than it has."""
    out: dict[str, list[Any]] = {"seed": [int(params["seed"]) + i for i in range(len(joints))]}
    arm = str(params.get("arm", "")).strip()
    if arm:
        drives = [aj.sim_defaults() for aj in arm_spec(arm).for_names(joints)]
        out.update({name: [d[name] for d in drives] for name in ARM_DEFAULTS})
    return out


class JointSimNode(Node):
    """The simulated robot as a ROS node (see the module docstring)."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__("joint_sim", **kwargs)  # type: ignore[arg-type]
        p, self.joints, self.values = declare_robot(self, PARAMETERS, PER_JOINT, per_joint_defaults)
        self.p = p
        self.arm = str(p["arm"]).strip().lower()
        self.joint_name = self.joints[0]
        configs = []
        for j in self.joints:
            try:
                c = joint_config(self.values[j])
                c.check()
            except ParameterError as exc:
                raise ParameterError(f"{j}: {exc}") from None
            configs.append(c)
        seeds = [int(self.values[j]["seed"]) for j in self.joints]
        self.sim: RobotSim | ArmSim
        #: the arm (with ``arm``), else None
        self.arm_sim: ArmSim | None = None
        if self.arm:
            from ..sim import ArmSim  # loads Pinocchio: only for an arm

            self.sim = self.arm_sim = ArmSim(arm_spec(self.arm), self.joints, configs, seeds,
                                             payload=float(p["payload"]), physics_rate=float(p["physics_rate"]))
        else:
            self.sim = RobotSim(self.joints, configs, seeds)
            if float(p["payload"]) != 0.0:
                self.get_logger().warning(f"payload={float(p['payload']):g} kg has no effect without an arm "
                                          f"(parameter arm: {', '.join(ARMS)})")
        self.max_velocity = [float(self.values[j]["max_velocity"]) for j in self.joints]
        self.dt = 1.0 / float(p["publish_rate"])
        self.publish_clock = bool(p["publish_clock"])
        self.rtf = float(p["real_time_factor"])
        self.command_timeout = float(p["command_timeout"])
        self.max_lag = float(p["max_lag"])
        self.temperature_period = 1.0 / float(p["temperature_rate"])
        self.bad_commands = 0
        self.samples_published = 0
        self._bad_reported = dict.fromkeys(self.joints, 0)
        self._last_command_time: float | None = None
        self._last_command_wall = -math.inf
        self.lockstep = bool(p["lockstep"])
        self.lockstep_lead = float(p["lockstep_lead"])
        self.lockstep_grace = float(p["lockstep_grace"])
        self.lockstep_rest_grace = float(p["lockstep_rest_grace"])
        #: ticks at which the clock waited for a late controller
        self.lockstep_holds = 0
        self._timed_out = True
        self._next_temperature = 0.0

        self.js_pub = self.create_publisher(JointState, "/joint_states", _RELIABLE_1000,
                                            qos_overriding_options=overridable_qos())
        self.temp_pub = (
            self.create_publisher(Temperature, "/joint_temperature", _RELIABLE_10)
            if bool(p["publish_temperature"])
            else None
        )
        self.clock_pub = self.create_publisher(ClockMsg, "/clock", _RELIABLE_10) if self.publish_clock else None
        self.create_subscription(Float64MultiArray, str(p["command_topic"]), self._on_command, _RELIABLE_10)

        if self.publish_clock:
            self._wall = Clock(clock_type=ClockType.STEADY_TIME)
            self.epoch = float(math.floor(time.time()))
            self._wall0 = time.monotonic()
            self.create_timer(float(p["tick_period"]), self._tick, clock=self._wall)
        else:
            if self.rtf != 1.0:
                self.get_logger().warning(
                    f"real_time_factor={self.rtf:g} is ignored without publish_clock: the sim follows the node clock"
                )
            self.epoch = self.get_clock().now().nanoseconds * 1e-9
            self.create_timer(float(p["tick_period"]), self._tick, clock=Clock(clock_type=ClockType.STEADY_TIME))
        # health: one task per simulated joint, read at every update
        self.health = Updater(self, "joint_sim", period=float(p["diagnostics_period"]))
        for j in self.joints:
            self.health.add(j, partial(self._joint_health, j), hardware_id=j)
        self.health.update()
        live = [n for n in PER_JOINT if not _DECLS[n].read_only]
        self.add_pre_set_parameters_callback(propagate_node_level(live, self.joints))
        on_parameter_change(self, self._on_parameters,
                            LIVE_PARAMETERS + tuple(f"{j}.{n}" for j in self.joints for n in live))
        arm_joints = arm_spec(self.arm).for_names(self.joints) if self.arm else ()
        for i, (j, c) in enumerate(zip(self.joints, configs, strict=True)):
            where = f"{arm_joints[i].name} of the {self.arm}" if arm_joints else f"gravity {c.gravity_torque:g}"
            self.get_logger().info(
                f"simulating {j}: wear {c.wear:g}, {c.temperature:g} degC, {where}, "
                f"params {c.params}, seed {self.values[j]['seed']}"
                + (f", hidden effects {', '.join(c.hidden_effects)}" if c.hidden_effects else "")
            )
        self.get_logger().info(
            f"{len(self.joints)} joint(s) at {1.0 / self.dt:g} Hz"
            + (f", arm {self.arm} integrated at {float(p['physics_rate']):g} Hz, payload {float(p['payload']):g} kg"
               if self.arm else "")
            + (f", clock source at {self.rtf:g}x real time" if self.publish_clock else "")
        )

    # -- health and run-time parameters ----------------------------------------
    def _joint_health(self, joint: str, stat: Status) -> None:
        cfg = self.sim[joint].config
        new_bad = self.bad_commands - self._bad_reported[joint]
        self._bad_reported[joint] = self.bad_commands
        if new_bad:
            stat.summary(DiagnosticLevel.WARN, f"{new_bad} bad velocity command(s) ignored since the last report")
        else:
            stat.summary(DiagnosticLevel.OK, f"simulating {joint} at wear {cfg.wear:g}, {cfg.temperature:g} degC")
        stat.extend([("wear", f"{cfg.wear:g}"), ("temperature", f"{cfg.temperature:g}"),
                     ("sim_time", f"{self.sim.time:.3f}"), ("samples_published", str(self.samples_published)),
                     ("lockstep_holds", str(self.lockstep_holds)),
                     ("bad_commands", str(self.bad_commands))])

    def _on_parameters(self, changes: dict[str, object]) -> str | None:
        per_joint: dict[str, dict[str, Any]] = {}
        for k, v in changes.items():
            j, _, name = k.rpartition(".")
            if j in self.values:
                per_joint.setdefault(j, {})[name] = v
        if "temperature_rate" in changes and not float(changes["temperature_rate"]) > 0:  # type: ignore[arg-type]
            return f"temperature_rate {changes['temperature_rate']!r} must be > 0 Hz"
        if "payload" in changes and self.arm_sim is None:
            return f"payload applies to an arm; this joint_sim simulates independent joints (parameter arm: {', '.join(ARMS)})"
        # check every joint's new settings before applying any (all or none)
        new: dict[str, JointSimConfig] = {}
        for j, ch in per_joint.items():
            if _SIM_LIVE.intersection(ch):
                try:
                    cfg = joint_config({**self.values[j], **ch})
                    cfg.check()
                except ParameterError as exc:
                    return f"{j}: {exc}"
                new[j] = cfg
        for j, cfg in new.items():
            self.sim.reconfigure(j, cfg)
        if "payload" in changes and self.arm_sim is not None:
            self.arm_sim.set_payload(float(changes["payload"]))  # type: ignore[arg-type]
        for j, ch in per_joint.items():
            self.values[j].update(ch)
            if "max_velocity" in ch:
                self.max_velocity[self.sim.index[j]] = float(ch["max_velocity"])  # type: ignore[arg-type]
        if "command_timeout" in changes:
            self.command_timeout = float(changes["command_timeout"])  # type: ignore[arg-type]
        if "max_lag" in changes:
            self.max_lag = float(changes["max_lag"])  # type: ignore[arg-type]
        if "lockstep" in changes:
            self.lockstep = bool(changes["lockstep"])
        if "lockstep_lead" in changes:
            self.lockstep_lead = float(changes["lockstep_lead"])  # type: ignore[arg-type]
        if "lockstep_grace" in changes:
            self.lockstep_grace = float(changes["lockstep_grace"])  # type: ignore[arg-type]
        if "lockstep_rest_grace" in changes:
            self.lockstep_rest_grace = float(changes["lockstep_rest_grace"])  # type: ignore[arg-type]
        if "temperature_rate" in changes:
            self.temperature_period = 1.0 / float(changes["temperature_rate"])  # type: ignore[arg-type]
        if "real_time_factor" in changes:
            rtf = float(changes["real_time_factor"])  # type: ignore[arg-type]
            if self.publish_clock:  # keep sim time continuous: sim.time = (now - wall0) * rtf
                self._wall0 = time.monotonic() - self.sim.time / rtf
            self.rtf = rtf
        if per_joint:
            self.health.update()
        return None

    # -- inputs --------------------------------------------------------------
    def _reject(self, why: str) -> None:
        self.bad_commands += 1
        self.get_logger().warning(
            f"ignored velocity command #{self.bad_commands}: {why}; expected Float64MultiArray with "
            f"{len(self.joints)} finite value(s), data[i] = velocity of joint i of {list(self.joints)} (rad/s)",
            throttle_duration_sec=2.0,
        )

    def _on_command(self, msg: Float64MultiArray) -> None:
        data = [float(x) for x in msg.data]
        if len(data) != len(self.joints):
            self._reject(f"{len(data)} value(s) for {len(self.joints)} joint(s)")
            return
        bad = [f"data[{i}] = {v}" for i, v in enumerate(data) if not math.isfinite(v)]
        if bad:
            self._reject(f"{', '.join(bad)} not finite")
            return
        for i, v in enumerate(data):
            if abs(v) > self.max_velocity[i]:
                self.get_logger().warning(
                    f"velocity command {v:g} rad/s for {self.joints[i]} clamped to max_velocity "
                    f"{self.max_velocity[i]:g}", throttle_duration_sec=2.0
                )
                data[i] = math.copysign(self.max_velocity[i], v)
        self.sim.set_commands(data)
        self._last_command_time = self.sim.time
        self._last_command_wall = time.monotonic()
        self._timed_out = False

    # -- stepping ------------------------------------------------------------
    def _target_time(self) -> float:
        if self.publish_clock:
            return (time.monotonic() - self._wall0) * self.rtf
        return self.get_clock().now().nanoseconds * 1e-9 - self.epoch

    def _lockstep_limit(self) -> float | None:
        """The sim time the clock may reach now under lockstep (None: it runs free): ``lockstep_lead`` past the
        newest command while a controller streams (its last command less than ``lockstep_grace`` wall s ago)."""
        if not (self.lockstep and self.publish_clock) or self._last_command_time is None or self._timed_out:
            return None
        # every joint commanded to rest and then silence (test_cycle's zero at DONE, abort or a watchdog trip):
        # a clock held for lockstep_grace published no joint state, so a cycle requested then found its state
        # stale or, on sim time, sent no first command to release it (every second commissioning cycle failed
        # its wall watchdog); zeros streamed in a settle still hold it (the next sweep's first command must
        # not wait in the queue while the clock runs on)
        resting = not any(c != 0.0 for c in self.sim.commands)
        grace = min(self.lockstep_rest_grace, self.lockstep_grace) if resting else self.lockstep_grace
        if time.monotonic() - self._last_command_wall > grace:
            return None
        return self._last_command_time + self.lockstep_lead

    def _tick(self) -> None:
        target = self._target_time()
        hold = self._lockstep_limit()
        if hold is not None and target > max(hold, self.sim.time):
            # the controller is late (a starved process): hold the clock for it instead of running away;
            # sim time resumes from here (sim.time = (now - wall0) * rtf stays continuous)
            held = max(hold, self.sim.time)
            self._wall0 += (target - held) / self.rtf
            self.lockstep_holds += 1
            target = held
        lag = target - self.sim.time
        if lag > self.max_lag:
            # behind (loaded machine): step at most max_lag, the sim runs slower than asked
            if self.publish_clock:
                self._wall0 += (lag - self.max_lag) / self.rtf
            target = self.sim.time + self.max_lag
        n = int((target - self.sim.time) / self.dt + 1e-9)
        if n <= 0:
            return
        self.advance(n)

    def advance(self, n: int) -> None:
        """Step and publish ``n`` samples, then the temperatures and clock when due."""
        sim = self.sim
        names = list(self.joints)
        for _ in range(n):
            if (
                not self._timed_out
                and self._last_command_time is not None
                and sim.time - self._last_command_time > self.command_timeout
            ):
                self._timed_out = True
                if any(c != 0.0 for c in sim.commands):
                    self.get_logger().warning(
                        f"no velocity command for {self.command_timeout:g} s: decelerating {', '.join(names)} to 0 "
                        "(a real forward command controller would hold the last command)"
                    )
                sim.stop()
            sim.step(self.dt)
            pos, vel, eff = sim.sample()
            msg = JointState()
            msg.header.stamp = seconds_to_stamp(self.epoch + sim.time)
            msg.name = names
            msg.position = pos
            msg.velocity = vel
            msg.effort = eff
            self.js_pub.publish(msg)
            self.samples_published += 1
        if self.temp_pub is not None and sim.time >= self._next_temperature:
            self._next_temperature = sim.time + self.temperature_period
            stamp = seconds_to_stamp(self.epoch + sim.time)
            for j, joint in zip(names, sim.joints, strict=True):
                tm = Temperature()
                tm.header.stamp = stamp
                tm.header.frame_id = j
                tm.temperature = float(joint.config.temperature)
                tm.variance = 0.0
                self.temp_pub.publish(tm)
        if self.clock_pub is not None:
            self.clock_pub.publish(ClockMsg(clock=seconds_to_stamp(self.epoch + sim.time)))


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point ``joint_sim``: exit status 2 with one line on stderr for a bad start-up setting
    (an unknown arm, more joints than the arm has, a value out of range)."""
    # the C++ EventsExecutor: less CPU per tick and per command than the Python executor (docs/testing.md, stop 42)
    return run_node_refusing("joint_sim", JointSimNode, args, events=True)

if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
