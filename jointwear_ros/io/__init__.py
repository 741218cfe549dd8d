"""Adapters between files/bags and the core's data types (no ROS runtime needed)."""
