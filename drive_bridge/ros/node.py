"""The bus node: one per CAN bus."""
from __future__ import annotations

from pathlib import Path

import canopen
import rclpy
import yaml
from drive_bridge_interfaces.msg import CanFrame
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from drive_bridge.master.bus import FrameTap, TappedBus, open_bus
from drive_bridge.master.sync import SyncProducer
from drive_bridge.ros.frames import to_frame_msg


class BusNode(Node):
    """Owns the CAN bus of one configuration and publishes its frames."""

    def __init__(self, config_path: str) -> None:
        super().__init__('drive_bridge')
        path = self.declare_parameter('config', config_path).value
        settings = yaml.safe_load(Path(path).read_text())
        bus_cfg = settings['bus']
        self.channel = str(bus_cfg['channel'])
        self.frames_pub = self.create_publisher(CanFrame, '~/can_frames', 100)
        self.tap = FrameTap()
        self.tap.add_listener(lambda m: self.frames_pub.publish(to_frame_msg(m, self.channel)))
        self.bus = TappedBus(open_bus(bus_cfg['interface'], bus_cfg['channel'], bus_cfg.get('bitrate')), self.tap)
        self.network = canopen.Network(self.bus)
        self.network.connect()
        period_us = settings['master'].get('sync_period', 0)
        self.sync = SyncProducer(self.network.send_message, period_us / 1e6)
        self.sync.start()
        self.get_logger().info(f'bus {bus_cfg["interface"]}:{self.channel} open, SYNC every {period_us} us')

    def close(self) -> None:
        self.sync.stop()
        self.network.disconnect()


def run(config_path: str, args: list[str]) -> None:
    """Spin the node until Ctrl-C."""
    rclpy.init(args=args)
    node = BusNode(config_path)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.close()
        executor.shutdown()
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
