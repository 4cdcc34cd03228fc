"""The bus node: one per CAN bus, active from the start, owning the core master of that bus."""
from __future__ import annotations

from rclpy.node import Node

from drive_bridge.busproc.client import BusClient
from drive_bridge.busproc.executor import ExecutorProxy
from drive_bridge.ros.bridge import Bridge, declare_and_load
from drive_bridge.ros.callback_guard import GuardedCallbacks
from drive_bridge.ros.errors import StartupError
from drive_bridge.ros.parameters import BridgeParameters, watch

__all__ = ['BusNode', 'StartupError']


class BusNode(GuardedCallbacks, Node):
    """Bridges the drives of one bus into ROS, active from the start (docs/interfaces.md)."""

    def __init__(self, config_path: str = '', *, node_name: str = 'drive_bridge', **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.params, config = declare_and_load(self, config_path)
        self.bridge = Bridge(self, self.params, config)
        watch(self, lambda: self.params, self._apply)
        self.bridge.set_active(True)

    def _apply(self, params: BridgeParameters) -> None:
        self.params = params
        self.bridge.apply_parameters(params)

    @property
    def master(self) -> BusClient:
        """The bus process's client (the Master's API, across the boundary)."""
        return self.bridge.master

    @property
    def trajectories(self) -> ExecutorProxy:
        return self.bridge.trajectories

    def close(self) -> None:
        self.bridge.close()

    def abandon(self) -> None:
        """This process is dying: its bus process stops the axes as for a lost node."""
        self.bridge.abandon()

    def destroy_node(self) -> None:
        """Destroying the node ends its bus process too (stopping the axes first)."""
        self.bridge.close()
        super().destroy_node()
