"""``joint_sim``: a simulated robot joint behind ros2_control conventions.

Subscribes the velocity command of a JointGroupVelocityController
(``std_msgs/Float64MultiArray``, ``data[0]`` = joint velocity, rad/s), publishes
``/joint_states`` (position rad, velocity rad/s, effort N·m; joint side) at
``publish_rate``, the joint temperature (``sensor_msgs/Temperature``) when
``publish_temperature`` is set and ``/clock`` when ``publish_clock`` is set.
The dynamics are :class:`jointwear_ros.sim.JointSim` (one integration step per
published sample).

Time: with ``publish_clock`` the simulator is the graph's clock source and
advances at wall time × ``real_time_factor`` (stamps and ``/clock`` are sim
time, starting at the wall-clock time of start-up); without it, it follows the
node clock (``use_sim_time`` honoured) and ``real_time_factor`` is ignored.

Unlike a real forward command controller, which holds the last command forever,
the simulator brings the joint to rest when no command has arrived for
``command_timeout`` seconds (sim time), so a crashed client never leaves the
simulated joint running into its limits.

Run-time parameters: the physical settings (``wear``, ``temperature``,
gravity, hidden effects, gains, noise, ...) and ``command_timeout``,
``max_velocity``, ``real_time_factor``, ``max_lag``, ``temperature_rate`` apply at
once (``ros2 param set /joint_sim wear 40.0``: the next sample has the new
friction); an invalid value is refused with the reason. The joint's identity
and wiring (``joint_name``, topics, ``gear_ratio``, ``torque_scale``, ``params``,
``seed``, ``publish_*``, ``initial_position``, ``tick_period``) are read at
start-up only (read-only parameters).

Diagnostics: ``joint_sim: <joint>`` on ``/diagnostics`` (OK; WARN while bad
velocity commands arrive), key/values wear, temperature, sim_time,
samples_published, bad_commands.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import replace

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64MultiArray

from ..data.synth import HIDDEN_EFFECTS
from ..errors import ParameterError
from ..sim import JointSim, JointSimConfig
from .diagnostics import OK, WARN, NodeDiagnostics, Report
from .runtime import ParamDecl, declare_parameters, on_parameter_change, overridable_qos, run_node, seconds_to_stamp

__all__ = ["LIVE_PARAMETERS", "PARAMETERS", "JointSimNode", "main"]

#: Parameters of the node (defaults as in ``config/joint_sim.yaml``).
PARAMETERS: tuple[ParamDecl, ...] = (
    ParamDecl("joint_name", "joint_1", "name of the simulated joint in /joint_states", read_only=True),
    ParamDecl("command_topic", "/velocity_controller/commands", "velocity command topic (Float64MultiArray)", read_only=True),
    ParamDecl("gear_ratio", 100.0, "motor speed / joint speed", 1e-3, 1e6, read_only=True),
    ParamDecl("torque_scale", 200.0, "N·m (joint side) per normalized torque unit", 1e-6, 1e9, read_only=True),
    ParamDecl("publish_rate", 500.0, "JointState rate = integration rate, Hz (sim time)", 50.0, 20000.0, read_only=True),
    ParamDecl("publish_temperature", True, "publish /joint_temperature", read_only=True),
    ParamDecl("temperature_rate", 10.0, "temperature publish rate, Hz (sim time)", 0.1, 1000.0),
    ParamDecl("publish_clock", False, "be the clock source: publish /clock, step on wall time × real_time_factor", read_only=True),
    ParamDecl("real_time_factor", 1.0, "sim seconds per wall second (with publish_clock)", 0.01, 100.0),
    ParamDecl("command_timeout", 0.5, "sim s without a command after which the sim decelerates to 0", 0.0, 1e6),
    ParamDecl("max_velocity", 3.0, "largest accepted |command|, joint rad/s (larger ones are clamped)", 0.0, 1e3),
    ParamDecl("wear", 0.0, "true wear level 0-100", 0.0, 100.0),
    ParamDecl("temperature", 40.0, "joint temperature, degC", -50.0, 200.0),
    ParamDecl("gravity_torque", 0.1, "gravity amplitude g (normalized): tau_g = g cos(phi - gravity_angle)", -10.0, 10.0),
    ParamDecl("gravity_angle", 0.0, "joint angle of the largest gravity torque, rad", -10.0, 10.0),
    ParamDecl("hidden_effects", "", "comma-separated hidden friction effects: " + ", ".join(HIDDEN_EFFECTS)),
    ParamDecl("lube_hours", 0.0, "hours since lubrication (lubrication effect)", 0.0, 1e6),
    ParamDecl("params", "ref-2011r", "friction parameter set", read_only=True),
    ParamDecl("seed", 0, "seed of the noise generator", read_only=True),
    ParamDecl("initial_position", 0.0, "joint position at start, rad", -100.0, 100.0, read_only=True),
    ParamDecl("inertia", 5.0e-4, "motor-side inertia, normalized torque per rad/s^2", 1e-9, 1e3),
    ParamDecl("kp", 0.05, "velocity PI proportional gain, normalized torque per motor rad/s", 0.0, 1e3),
    ParamDecl("ki", 1.0, "velocity PI integral gain, normalized torque per motor rad", 0.0, 1e6),
    ParamDecl("accel_limit", 8.0, "reference acceleration limit of the drive, joint rad/s^2 (0: none)", 0.0, 1e6),
    ParamDecl("torque_limit", 1.0, "saturation of the applied torque, normalized", 1e-6, 1e3),
    ParamDecl("noise_std", 0.0015, "target scatter sigma_e of (u+ - u-)/2, normalized", 0.0, 1.0),
    ParamDecl("effort_noise_std", 0.003, "white noise on each effort sample, normalized", 0.0, 1.0),
    ParamDecl("tick_period", 0.005, "wall-clock period of the stepping timer, s", 1e-4, 1.0, read_only=True),
    ParamDecl("max_lag", 0.1, "largest sim-time backlog stepped in one tick, s (beyond: the sim slows)", 1e-3, 10.0),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications (wall time)", 0.01, 60.0,
              read_only=True),
)
#: JointSimConfig fields that can change on a running simulation
_SIM_FIELDS = ("inertia", "gravity_torque", "gravity_angle", "temperature", "wear", "hidden_effects", "lube_hours",
               "kp", "ki", "accel_limit", "torque_limit", "noise_std", "effort_noise_std")
#: Parameters that can change at run time
LIVE_PARAMETERS = tuple(d.name for d in PARAMETERS if not d.read_only)

_RELIABLE_1000 = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
_RELIABLE_10 = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


def parse_effects(text: str) -> tuple[str, ...]:
    """``"ripple, load_viscous"`` -> ``("ripple", "load_viscous")``, checking each name."""
    names = tuple(s.strip() for s in text.replace(";", ",").split(",") if s.strip())
    unknown = [n for n in names if n not in HIDDEN_EFFECTS]
    if unknown:
        raise ParameterError(
            f"joint_sim: unknown hidden effect(s) {', '.join(unknown)} in hidden_effects={text!r}; "
            f"known: {', '.join(HIDDEN_EFFECTS)}"
        )
    return names


class JointSimNode(Node):
    """The simulated joint as a ROS node (see the module docstring)."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__("joint_sim", **kwargs)  # type: ignore[arg-type]
        p = declare_parameters(self, PARAMETERS)
        self.p = p
        self.joint_name = str(p["joint_name"])
        cfg = JointSimConfig(
            gear_ratio=float(p["gear_ratio"]),
            torque_scale=float(p["torque_scale"]),
            inertia=float(p["inertia"]),
            gravity_torque=float(p["gravity_torque"]),
            gravity_angle=float(p["gravity_angle"]),
            params=str(p["params"]),
            temperature=float(p["temperature"]),
            wear=float(p["wear"]),
            hidden_effects=parse_effects(str(p["hidden_effects"])),
            lube_hours=float(p["lube_hours"]),
            kp=float(p["kp"]),
            ki=float(p["ki"]),
            torque_limit=float(p["torque_limit"]),
            accel_limit=float(p["accel_limit"]),
            noise_std=float(p["noise_std"]),
            effort_noise_std=float(p["effort_noise_std"]),
            initial_position=float(p["initial_position"]),
        )
        self.sim = JointSim(cfg, seed=int(p["seed"]))
        self.dt = 1.0 / float(p["publish_rate"])
        self.publish_clock = bool(p["publish_clock"])
        self.rtf = float(p["real_time_factor"])
        self.command_timeout = float(p["command_timeout"])
        self.max_velocity = float(p["max_velocity"])
        self.max_lag = float(p["max_lag"])
        self.temperature_period = 1.0 / float(p["temperature_rate"])
        self.bad_commands = 0
        self.samples_published = 0
        self._bad_reported = 0
        self._last_command_time: float | None = None
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
        self.diag = NodeDiagnostics(self, f"joint_sim: {self.joint_name}", self.joint_name,
                                    period=float(p["diagnostics_period"]), refresh=self._report)
        self.diag.update(*self._report())
        on_parameter_change(self, self._on_parameters, LIVE_PARAMETERS)
        self.get_logger().info(
            f"simulating {self.joint_name}: wear {cfg.wear:g}, {cfg.temperature:g} degC, gravity {cfg.gravity_torque:g}, "
            f"{1.0 / self.dt:g} Hz"
            + (f", clock source at {self.rtf:g}x real time" if self.publish_clock else "")
            + (f", hidden effects {', '.join(cfg.hidden_effects)}" if cfg.hidden_effects else "")
        )

    # -- health and run-time parameters ----------------------------------------
    def _report(self) -> Report:
        cfg = self.sim.config
        new_bad = self.bad_commands - self._bad_reported
        self._bad_reported = self.bad_commands
        values = [("wear", f"{cfg.wear:g}"), ("temperature", f"{cfg.temperature:g}"), ("sim_time", f"{self.sim.time:.3f}"),
                  ("samples_published", str(self.samples_published)), ("bad_commands", str(self.bad_commands))]
        if new_bad:
            return WARN, f"{new_bad} bad velocity command(s) ignored since the last report", values
        return OK, f"simulating {self.joint_name} at wear {cfg.wear:g}, {cfg.temperature:g} degC", values

    def _on_parameters(self, changes: dict[str, object]) -> str | None:
        sim_changes: dict[str, object] = {}
        for k, v in changes.items():
            if k == "hidden_effects":
                sim_changes[k] = parse_effects(str(v))
            elif k in _SIM_FIELDS:
                sim_changes[k] = float(v)  # type: ignore[arg-type]
        if "temperature_rate" in changes and not float(changes["temperature_rate"]) > 0:  # type: ignore[arg-type]
            return f"temperature_rate {changes['temperature_rate']!r} must be > 0 Hz"
        if sim_changes:
            self.sim.reconfigure(replace(self.sim.config, **sim_changes))  # type: ignore[arg-type]
        if "command_timeout" in changes:
            self.command_timeout = float(changes["command_timeout"])  # type: ignore[arg-type]
        if "max_velocity" in changes:
            self.max_velocity = float(changes["max_velocity"])  # type: ignore[arg-type]
        if "max_lag" in changes:
            self.max_lag = float(changes["max_lag"])  # type: ignore[arg-type]
        if "temperature_rate" in changes:
            self.temperature_period = 1.0 / float(changes["temperature_rate"])  # type: ignore[arg-type]
        if "real_time_factor" in changes:
            rtf = float(changes["real_time_factor"])  # type: ignore[arg-type]
            if self.publish_clock:  # keep sim time continuous: sim.time = (now - wall0) * rtf
                self._wall0 = time.monotonic() - self.sim.time / rtf
            self.rtf = rtf
        self.diag.update(*self._report())
        return None

    # -- inputs --------------------------------------------------------------
    def _reject(self, why: str) -> None:
        self.bad_commands += 1
        self.get_logger().warning(
            f"ignored velocity command #{self.bad_commands}: {why}; expected Float64MultiArray with "
            f"finite data[0] = joint velocity (rad/s)",
            throttle_duration_sec=2.0,
        )

    def _on_command(self, msg: Float64MultiArray) -> None:
        if len(msg.data) < 1:
            self._reject("empty data")
            return
        v = float(msg.data[0])
        if not math.isfinite(v):
            self._reject(f"data[0] = {v} is not finite")
            return
        if abs(v) > self.max_velocity:
            self.get_logger().warning(
                f"velocity command {v:g} rad/s clamped to max_velocity {self.max_velocity:g}", throttle_duration_sec=2.0
            )
            v = math.copysign(self.max_velocity, v)
        self.sim.set_command(v)
        self._last_command_time = self.sim.time
        self._timed_out = False

    # -- stepping ------------------------------------------------------------
    def _target_time(self) -> float:
        if self.publish_clock:
            return (time.monotonic() - self._wall0) * self.rtf
        return self.get_clock().now().nanoseconds * 1e-9 - self.epoch

    def _tick(self) -> None:
        target = self._target_time()
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
        """Step and publish ``n`` samples, then the temperature and clock when due."""
        sim = self.sim
        name = [self.joint_name]
        for _ in range(n):
            if (
                not self._timed_out
                and self._last_command_time is not None
                and sim.time - self._last_command_time > self.command_timeout
            ):
                self._timed_out = True
                if sim.command != 0.0:
                    self.get_logger().warning(
                        f"no velocity command for {self.command_timeout:g} s: decelerating {self.joint_name} to 0 "
                        "(a real forward command controller would hold the last command)"
                    )
                sim.set_command(0.0)
            sim.step(self.dt)
            s = sim.sample()
            msg = JointState()
            msg.header.stamp = seconds_to_stamp(self.epoch + s.time)
            msg.name = name
            msg.position = [s.position]
            msg.velocity = [s.velocity]
            msg.effort = [s.effort]
            self.js_pub.publish(msg)
            self.samples_published += 1
        if self.temp_pub is not None and sim.time >= self._next_temperature:
            self._next_temperature = sim.time + self.temperature_period
            tm = Temperature()
            tm.header.stamp = seconds_to_stamp(self.epoch + sim.time)
            tm.header.frame_id = self.joint_name
            tm.temperature = float(sim.config.temperature)
            tm.variance = 0.0
            self.temp_pub.publish(tm)
        if self.clock_pub is not None:
            self.clock_pub.publish(ClockMsg(clock=seconds_to_stamp(self.epoch + sim.time)))


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point ``joint_sim``."""
    return run_node(JointSimNode, args)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
