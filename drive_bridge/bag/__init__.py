"""rosbag2 (MCAP) for diagnosis: record the bus, import vendor traces, replay, diagnose, scan.

Built on ``rosbags`` (no rclpy): the bag tools run on a laptop without ROS installed.
"""
