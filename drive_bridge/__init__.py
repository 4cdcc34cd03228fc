"""drive_bridge: CANopen servo drives in a ROS 2 robot stack.

Layers, top to bottom: cli, ros, streaming | master, config, families, cia402, joint,
cia301 | model, errors (enforced by .importlinter). The core never imports rclpy or the
simulator; the ROS layer (``drive_bridge.ros``) never builds CAN frames; the drive family
(``drive_bridge.families``) is the one boundary the core asks about a drive line.
"""

__version__ = '0.1.0'
