"""Test set-up: every ROS test stays on loopback, on a domain of its own."""

from __future__ import annotations

import os
import random

# Before anything imports rclpy: DDS discovery on loopback only, and a
# per-run domain so parallel runs on one machine do not see each other.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.Random(os.getpid()).randint(10, 99)))
os.environ.setdefault("MPLBACKEND", "Agg")
