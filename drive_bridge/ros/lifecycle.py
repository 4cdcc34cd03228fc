"""The managed (lifecycle) bus node: a stack can boot the drives without enabling motion.

configure  = read the parameters, load the configuration, open the bus, boot the nodes (no axis
             is enabled); from here until cleanup the start-time parameters are read-only
activate   = publish state, accept commands and services (auto_enable enables here)
deactivate = halt motion (HALT bit, trajectories stopped with a deceleration), refuse commands
cleanup    = quick-stop enabled axes, close the bus
"""
from __future__ import annotations

from collections.abc import Callable

from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn

from drive_bridge.ros.bridge import Bridge, configuration, with_config_path
from drive_bridge.ros.callback_guard import GuardedCallbacks
from drive_bridge.ros.errors import NodeParameterRefused, StartupError
from drive_bridge.ros.parameters import BridgeParameters, declare, read, watch


class BusLifecycleNode(GuardedCallbacks, LifecycleNode):
    """The bus node with the standard lifecycle (~/change_state, ~/get_state)."""

    def __init__(self, config_path: str = '', *, node_name: str = 'drive_bridge', **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.config_path = config_path
        self.bridge: Bridge | None = None
        self.params: BridgeParameters | None = None
        self.on_bus_started: Callable[[int], None] | None = None  # (node_nice) once a bus process runs
        try:
            self.params = declare(self)
        except NodeParameterRefused as exc:
            self.get_logger().error(str(exc))  # configure will fail and say so again
        # unconfigured: anything may be set (configure reads and checks it); configured: guarded
        watch(self, lambda: self.params if self.bridge is not None else None, self._apply)

    def _apply(self, params: BridgeParameters) -> None:
        self.params = params
        if self.bridge is not None:
            self.bridge.apply_parameters(params)

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        try:
            params = with_config_path(read(self), self.config_path)  # the values set since start count
        except NodeParameterRefused as exc:
            self.get_logger().error(f'cannot configure: {exc}')
            return TransitionCallbackReturn.FAILURE
        try:
            self.bridge = Bridge(self, params, configuration(params))
        except StartupError as exc:
            self.get_logger().error(f'cannot configure: {exc}')
            return TransitionCallbackReturn.FAILURE
        self.params = params
        if self.on_bus_started is not None:
            self.on_bus_started(params.node_nice)
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self.bridge is None:
            return TransitionCallbackReturn.FAILURE
        self.bridge.set_active(True)
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self.bridge is not None:
            self.bridge.set_active(False)
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def _release(self) -> None:
        if self.bridge is not None:
            self.bridge.close()
            self.bridge = None

    def close(self) -> None:
        self._release()

    def abandon(self) -> None:
        """This process is dying: its bus process (if configured) stops the axes as for a lost node."""
        if self.bridge is not None:
            self.bridge.abandon()

    def destroy_node(self) -> None:
        """Destroying the node ends its bus process too (stopping the axes first)."""
        self._release()
        super().destroy_node()
