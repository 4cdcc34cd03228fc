"""The bus node: one per CAN bus, owning the core master of that bus."""
from __future__ import annotations

import dataclasses
import threading
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from drive_bridge.config import ConfigError, load_bus_config, parse_bus_config
from drive_bridge.config.model import BusConfig
from drive_bridge.master.events import BusEvent, Level
from drive_bridge.master.master import UPDATE_PERIOD_WITHOUT_SYNC, Master
from drive_bridge.ros.command_topics import CommandTopics
from drive_bridge.ros.parameters import BridgeParameters, ParameterError, declare
from drive_bridge.ros.services import BridgeServices
from drive_bridge.ros.state_topics import StateTopics
from drive_bridge.ros.trajectory_action import TrajectoryAction
from drive_bridge.streaming.executor import TrajectoryExecutor

AUTO_ENABLE_TIMEOUT = 30.0


class StartupError(RuntimeError):
    """The node cannot start: bad parameters or configuration (the message says what)."""


def load_config(params: BridgeParameters) -> BusConfig:
    """The bus configuration from the parameters, with the sync_period override applied."""
    if params.config_yaml:
        import yaml
        try:
            data = yaml.safe_load(params.config_yaml)
        except yaml.YAMLError as exc:
            raise StartupError(f'parameter config_yaml is not valid YAML: {exc}') from None
        config = parse_bus_config(data, 'parameter config_yaml', Path.cwd())
    elif params.config:
        config = load_bus_config(Path(params.config))
    else:
        raise StartupError('no bus configuration: set the parameter config (a YAML file) or config_yaml')
    if params.sync_period > 0:
        config = dataclasses.replace(config, master=dataclasses.replace(config.master, sync_period=params.sync_period))
    if params.simulate and not config.simulation.enabled:
        if config.bus.interface != 'virtual':
            raise StartupError(f'parameter simulate needs the virtual CAN interface; the configuration '
                               f'uses {config.bus.interface!r}')
        config = dataclasses.replace(config, simulation=dataclasses.replace(config.simulation, enabled=True))
    return config


class BusNode(Node):
    """Bridges the drives of one bus into ROS (see README: topics, services, parameters)."""

    def __init__(self, config_path: str = '', *, node_name: str = 'drive_bridge', **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        try:
            self.params = declare(self)
        except ParameterError as exc:
            raise StartupError(str(exc)) from None
        if not self.params.config and not self.params.config_yaml and config_path:
            self.params = dataclasses.replace(self.params, config=config_path)
        try:
            self.config = load_config(self.params)
        except ConfigError as exc:
            raise StartupError(f'bus configuration refused:\n{exc}') from None
        for warning in self.config.warnings:
            self.get_logger().warning(f'configuration: {warning}')
        self.simulation = None
        if self.config.simulation.enabled:
            from drive_bridge.sim import SimulatedBus
            self.simulation = SimulatedBus(self.config)
            self.simulation.start()
        self.master = Master(self.config)
        self.master.add_event_listener(self._log_event)
        self.master.start()
        self.trajectories = TrajectoryExecutor(
            self.master.axes, cycle_period=self.config.master.sync_period or UPDATE_PERIOD_WITHOUT_SYNC,
            pvt_segment=self.params.pvt_segment, pvt_lookahead=self.params.pvt_lookahead)
        self.master.add_cycle_listener(self.trajectories.check)
        self.master.add_emcy_listener(self.trajectories.on_emcy)
        self.state_topics = StateTopics(self, self.master, self.params)
        self.command_topics = CommandTopics(self, self.master, self.trajectories, self.params)
        self.service_handlers = BridgeServices(self, self.master, self.trajectories)
        self.trajectory_action = TrajectoryAction(self, self.master, self.trajectories)
        self.state_topics.attach()
        self.set_active(True)
        bus = self.config.bus
        sync = self.config.master.sync_period
        self.get_logger().info(
            f'bus {bus.interface}:{bus.channel} open with {len(self.master.nodes)} node(s), '
            f'{len(self.master.axes)} joint(s); SYNC {"every %.1f ms" % (sync * 1000) if sync else "off"}'
            f'{"; simulated drives" if self.simulation else ""}')
        if self.params.auto_enable:
            threading.Thread(target=self._auto_enable, daemon=True, name='drive_bridge-auto-enable').start()

    def set_active(self, active: bool) -> None:
        """Active: publish state and accept commands. Inactive: stop accepting, halt motion."""
        self.state_topics.active = active
        self.command_topics.active = active
        self.service_handlers.active = active
        self.trajectory_action.active = active
        if not active:
            self.trajectories.stop(list(self.master.axes), 'bridge deactivated')
            for axis in self.master.axes.values():
                if axis.node.available:
                    axis.halt(True)

    def _log_event(self, event: BusEvent) -> None:
        logger = self.get_logger()
        {Level.INFO: logger.info, Level.WARN: logger.warning, Level.ERROR: logger.error}[event.level](event.message)

    def _auto_enable(self) -> None:
        try:
            self.master.wait_until_operational(AUTO_ENABLE_TIMEOUT)
        except TimeoutError as exc:
            self.get_logger().error(f'auto_enable: {exc}')
        for axis in self.master.axes.values():
            if not axis.node.available:
                continue
            try:
                axis.enable()
            except Exception as exc:
                self.get_logger().error(f'auto_enable: {exc}')
        self.get_logger().info('auto_enable: done')

    def close(self) -> None:
        """Stop motion safely and release the bus (and the simulated drives)."""
        self.state_topics.active = self.command_topics.active = False
        self.trajectories.stop(list(self.master.axes), 'bridge shutting down')
        self.master.stop()
        if self.simulation is not None:
            self.simulation.stop()
        self.service_handlers.pool.shutdown(wait=False, cancel_futures=True)
        self.service_handlers.joint_pool.shutdown(wait=False, cancel_futures=True)


def run(config_path: str, args: list[str]) -> int:
    """Spin a bus node until Ctrl-C; returns the process exit code."""
    rclpy.init(args=args)
    try:
        node = BusNode(config_path)
    except StartupError as exc:
        rclpy.logging.get_logger('drive_bridge').fatal(str(exc))
        rclpy.try_shutdown()
        return 2
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
        rclpy.try_shutdown()
    return 0
