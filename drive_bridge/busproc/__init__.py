"""The bus process and its boundary with the node process.

The SYNC cycle, the CAN I/O, boot and supervision, the trajectory executor, the limit check of
every set-point and the safety reactions run in a process of their own (:mod:`.process`),
started and supervised by the ROS node process (:mod:`.client`), so nothing a ROS client
makes the node do can take the cycle's time. Between them, three lanes (:mod:`.wire`): the
stop lane, the request lane (:mod:`.intents` one way, :mod:`.reports` the other) and the
cyclic state (:mod:`.cyclic`). Nothing here imports rclpy; the node side builds no CAN frames.
"""
