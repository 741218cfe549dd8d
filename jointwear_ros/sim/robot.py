"""A simulated robot: N joints behind one velocity command array (pure: numpy and the model core).

Each joint is its own :class:`~jointwear_ros.sim.JointSim` (its own friction
parameters, wear, temperature, gravity, noise generator) stepped on one clock.
The joints are mechanically independent: each motor sees its own friction and
gravity, as in the paper's one-joint model (coupling through the arm's inertia
is neglected, as the paper neglects it). The command array carries one
velocity per joint in :attr:`RobotSim.names` order, as a ros2_control
``JointGroupVelocityController`` does.

Cost: a loop over the joints in plain Python, a few microseconds per joint and
step (``bench/bench_sim.py`` prints the figures); at 500 Hz six joints take
about 3000 steps per simulated second.

>>> robot = RobotSim(["joint_1", "joint_2"], [JointSimConfig(), JointSimConfig(wear=40.0)], seeds=[0, 1])
>>> robot.set_commands([0.1, 0.0])
>>> for _ in range(500):
...     robot.step(0.002)
>>> pos, vel, eff = robot.sample()
>>> round(robot.time, 3), vel[0] > 0.09, vel[1] == 0.0
(1.0, True, True)
"""

from __future__ import annotations

from collections.abc import Sequence

from ..errors import ParameterError
from .joint import JointSim, JointSimConfig, command_all

__all__ = ["RobotSim"]


class RobotSim:
    """N simulated joints on one clock, driven by one command array.

    Parameters
    ----------
    names
        Joint names, in command-array order (unique, non-empty).
    configs
        One :class:`JointSimConfig` per joint.
    seeds
        One noise seed per joint (each joint draws from its own generator).
    """

    def __init__(self, names: Sequence[str], configs: Sequence[JointSimConfig], seeds: Sequence[int]) -> None:
        names = [str(n) for n in names]
        if not names:
            raise ParameterError("robot sim: give at least one joint name")
        if any(not n for n in names):
            raise ParameterError(f"robot sim: joint names must not be empty, got {names}")
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ParameterError(f"robot sim: joint name(s) {', '.join(dup)} given more than once in {names}")
        if not (len(configs) == len(names) == len(seeds)):
            raise ParameterError(
                f"robot sim: {len(names)} joint names need as many configs and seeds, got {len(configs)} and {len(seeds)}"
            )
        self.names: tuple[str, ...] = tuple(names)
        self.joints: tuple[JointSim, ...] = tuple(
            JointSim(cfg, seed=int(seed)) for cfg, seed in zip(configs, seeds, strict=True)
        )
        self.index = {n: i for i, n in enumerate(self.names)}

    def __len__(self) -> int:
        return len(self.joints)

    def __getitem__(self, name: str) -> JointSim:
        """The joint called ``name`` (``KeyError`` if there is none)."""
        return self.joints[self.index[name]]

    @property
    def time(self) -> float:
        """Simulated time, s (every joint steps on the same clock)."""
        return self.joints[0].time

    @property
    def commands(self) -> tuple[float, ...]:
        """The velocity commands being followed, joint side rad/s, in joint order."""
        return tuple(j.command for j in self.joints)

    def set_commands(self, velocities: Sequence[float]) -> None:
        """Set every joint's velocity command (joint rad/s, joint order); all or none.

        A wrong length or a non-finite entry raises :class:`ParameterError` and
        changes nothing.
        """
        command_all(self.joints, self.names, velocities)

    def stop(self) -> None:
        """Command zero velocity on every joint."""
        for j in self.joints:
            j.set_command(0.0)

    def reconfigure(self, name: str, config: JointSimConfig) -> None:
        """Apply new settings to one joint now (see :meth:`JointSim.reconfigure`)."""
        self[name].reconfigure(config)

    def step(self, dt: float) -> None:
        """Advance every joint by ``dt`` seconds."""
        for j in self.joints:
            j.step(dt)

    def sample(self) -> tuple[list[float], list[float], list[float]]:
        """Positions (rad), velocities (rad/s) and efforts (N·m, with noise), joint side, in joint order."""
        pos: list[float] = []
        vel: list[float] = []
        eff: list[float] = []
        for j in self.joints:
            s = j.sample()
            pos.append(s.position)
            vel.append(s.velocity)
            eff.append(s.effort)
        return pos, vel, eff
