"""rclpy nodes: thin adapters over the pure cores.

Each node module has a ``main(args=None)`` console entry point
(``ros2 run jointwear_ros <name>``) built with :func:`jointwear_ros.nodes.runtime.run_node`.
"""

__all__: list[str] = []
