"""The ROS 2 layer: one BusNode per CAN bus. Only this package imports rclpy."""
