"""What one bus node does, shared by the plain and the lifecycle node: load the configuration,
own the master (and the simulated drives), state topics, commands, services, the action."""
from __future__ import annotations

import dataclasses
import threading
from pathlib import Path

from rclpy.node import Node

from drive_bridge.bag.errors import BagError
from drive_bridge.config import ConfigError, load_bus_config, parse_bus_config
from drive_bridge.config.cycle import with_sync_period
from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint import DriveState
from drive_bridge.master.events import BusEvent, Level
from drive_bridge.master.master import UPDATE_PERIOD_WITHOUT_SYNC, Master
from drive_bridge.model import BusConfig
from drive_bridge.ros.callback_guard import failures_of
from drive_bridge.ros.command_topics import CommandTopics
from drive_bridge.ros.param_services import ParameterServices
from drive_bridge.ros.parameters import BridgeParameters, ParameterError, declare
from drive_bridge.ros.recording import RecordControl
from drive_bridge.ros.services import BridgeServices
from drive_bridge.ros.state_topics import StateTopics
from drive_bridge.ros.trajectory_action import TrajectoryAction
from drive_bridge.streaming.executor import TrajectoryExecutor

AUTO_ENABLE_TIMEOUT = 30.0


class StartupError(DriveBridgeError, RuntimeError):
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
    if params.sync_period > 0:  # checked as the file's own period is: window and bus budget
        config = with_sync_period(config, params.sync_period)
    if params.simulate and not config.simulation.enabled:
        if config.bus.interface != 'virtual':
            raise StartupError(f'parameter simulate needs the virtual CAN interface; the configuration '
                               f'uses {config.bus.interface!r}')
        config = dataclasses.replace(config, simulation=dataclasses.replace(config.simulation, enabled=True))
    return config


class Bridge:
    """Everything one bus node does, for a plain or a lifecycle node: the master (and the
    simulated drives), state topics, commands, services and the trajectory action."""

    def __init__(self, node: Node, params: BridgeParameters, config: BusConfig) -> None:
        self.node = node
        self.params = params
        self.config = config
        self._held: set[str] = set()  # joints halted by deactivation (resumed by activation)
        for warning in config.warnings:
            node.get_logger().warning(f'configuration: {warning}')
        self.simulation = None
        if config.simulation.enabled:
            from drive_bridge.sim import SimulatedBus
            self.simulation = SimulatedBus(config)
            self.simulation.start()
        existing = _entities(node)
        self.master = Master(config)
        self.master.add_event_listener(self._log_event)
        try:  # before the bus opens: record.start records from the first frame
            self.recording = RecordControl(node, self.master, config, config_text(params, config))
        except BagError as exc:
            if self.simulation is not None:
                self.simulation.stop()
            raise StartupError(str(exc)) from None
        try:
            self.master.start()
        except DriveBridgeError as exc:  # e.g. the interface cannot do what the configuration asks
            self.recording.close()
            if self.simulation is not None:
                self.simulation.stop()
            raise StartupError(f'cannot start bus {config.bus.interface}:{config.bus.channel}: {exc}') from None
        self.trajectories = TrajectoryExecutor(
            self.master.axes, cycle_period=config.master.sync_period or UPDATE_PERIOD_WITHOUT_SYNC,
            pvt_segment=params.pvt_segment, pvt_lookahead=params.pvt_lookahead,
            scale_to_limits=config.trajectory.scale_to_limits)
        self.master.add_cycle_listener(self.trajectories.check)
        self.master.add_emcy_listener(self.trajectories.on_emcy, safety=True)
        self.state_topics = StateTopics(node, self.master, params)
        self.command_topics = CommandTopics(node, self.master, self.trajectories, params)
        self.master.add_event_listener(self.command_topics.on_event)
        # a guarded callback that failed is a refused command there too
        failures_of(node).refuse = self.command_topics.refuse
        self.service_handlers = BridgeServices(node, self.master, self.trajectories)
        self.parameter_services = ParameterServices(node, self.master, self.service_handlers.pool)
        self.trajectory_action = TrajectoryAction(node, self.master, self.trajectories)
        self.state_topics.attach()
        self.state_topics.tee = self.recording.tee
        self.state_topics.diagnostic_sources.append(self.recording.status)
        self.recording.attach()
        self._entities = [e for e in _entities(node) if id(e) not in {id(x) for x in existing}]
        self.set_active(False)
        bus = config.bus
        sync = config.master.sync_period
        node.get_logger().info(
            f'bus {bus.interface}:{bus.channel} open with {len(self.master.nodes)} node(s), '
            f'{len(self.master.axes)} joint(s); SYNC {"every %.1f ms" % (sync * 1000) if sync else "off"}'
            f'{"; simulated drives" if self.simulation else ""}')

    def set_active(self, active: bool) -> None:
        """Active: publish state and accept commands. Inactive: halt motion (HALT bit), stop
        accepting commands; the drives stay enabled and report their state."""
        for part in (self.state_topics, self.command_topics, self.service_handlers, self.trajectory_action):
            part.active = active
        if active:
            for joint in sorted(self._held):
                axis = self.master.axes[joint]
                if axis.available:
                    axis.halt(False)
            self._held.clear()
            if self.params.auto_enable:
                threading.Thread(target=self._auto_enable, daemon=True, name='drive_bridge-auto-enable').start()
            return
        self.trajectories.stop(list(self.master.axes), 'bridge deactivated', smooth=True)
        for joint, axis in self.master.axes.items():
            if axis.drive_state is DriveState.ENABLED and not axis.snapshot().halted:
                axis.halt(True)
                self._held.add(joint)

    def apply_parameters(self, params: BridgeParameters) -> None:
        """Run-time parameter changes (ros/parameters.py validated them): rates and PVT timing."""
        self.params = params
        self.state_topics.apply(params)
        self.trajectories.pvt_segment, self.trajectories.pvt_lookahead = params.pvt_segment, params.pvt_lookahead

    def _log_event(self, event: BusEvent) -> None:
        # one call site per severity: rclpy refuses a call site that changes severity
        logger = self.node.get_logger()
        if event.level is Level.ERROR:
            logger.error(event.message)
        elif event.level is Level.WARN:
            logger.warning(event.message)
        else:
            logger.info(event.message)

    def _auto_enable(self) -> None:
        try:
            self.master.wait_until_operational(AUTO_ENABLE_TIMEOUT)
        except TimeoutError as exc:
            self.node.get_logger().error(f'auto_enable: {exc}')
        failed = []
        for joint, axis in self.master.axes.items():
            try:
                axis.enable()
            except Exception as exc:
                failed.append(joint)
                self.node.get_logger().error(f'auto_enable: {exc}')
        enabled = [j for j in self.master.axes if j not in failed]
        self.node.get_logger().info(f'auto_enable: enabled {", ".join(enabled) or "none"}'
                                    + (f'; failed {", ".join(failed)}' if failed else ''))

    def close(self) -> None:
        """Stop motion safely and release the bus (and the simulated drives)."""
        self.state_topics.active = self.command_topics.active = False
        self.trajectories.stop(list(self.master.axes), 'bridge shutting down')
        self.master.stop()
        self.recording.close()  # after the bus: the bag has every frame the tap counted
        if self.simulation is not None:
            self.simulation.stop()
        self.service_handlers.pool.shutdown(wait=False, cancel_futures=True)
        self.service_handlers.joint_pool.shutdown(wait=False, cancel_futures=True)
        self.trajectory_action.server.destroy()
        for entity in self._entities:  # a lifecycle node may configure again
            for kind in ('publisher', 'subscription', 'service', 'timer'):
                if entity in list(getattr(self.node, f'{kind}s')):
                    getattr(self.node, f'destroy_{kind}')(entity)


def _entities(node: Node) -> list:
    return [*node.publishers, *node.subscriptions, *node.services, *node.timers]


def config_text(params: BridgeParameters, config: BusConfig) -> str | None:
    """The bus configuration as the user wrote it, to store in a bag."""
    if params.config_yaml:
        return params.config_yaml
    try:
        return config.path.read_text(encoding='utf-8') if config.path is not None else None
    except (OSError, UnicodeDecodeError):
        return None


def declare_and_load(node: Node, config_path: str) -> tuple[BridgeParameters, BusConfig]:
    """The node's validated parameters and bus configuration (StartupError says what is wrong)."""
    try:
        params = declare(node)
    except ParameterError as exc:
        raise StartupError(str(exc)) from None
    return params, configuration(params, config_path)


def configuration(params: BridgeParameters, config_path: str) -> BusConfig:
    if not params.config and not params.config_yaml and config_path:
        params = dataclasses.replace(params, config=config_path)
    try:
        return load_config(params)
    except ConfigError as exc:
        raise StartupError(f'bus configuration refused:\n{exc}') from None
