"""drive_bridge: CANopen CiA 402 servo drives in a ROS 2 robot stack.

The core (config, master, cia402, streaming, families, sim) never imports rclpy;
the ROS layer (``drive_bridge.ros``) never builds CAN frames.
"""

__version__ = '0.1.0'
