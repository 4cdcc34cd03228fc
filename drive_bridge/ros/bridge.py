"""What one bus node does, shared by the plain and the lifecycle node: load the configuration,
start and supervise the bus process (the Master, the cycle and the simulated drives run there,
:mod:`drive_bridge.busproc`), state topics, commands, services, the action."""
from __future__ import annotations

import dataclasses
import threading
from pathlib import Path

from rclpy.node import Node

from drive_bridge.bag.errors import BagError
from drive_bridge.busproc.client import BusClient
from drive_bridge.busproc.errors import BusProcessStartError
from drive_bridge.config import ConfigError
from drive_bridge.config.source import ConfigSource, load
from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint import DriveState
from drive_bridge.master.events import BusEvent, Level
from drive_bridge.model import BusConfig
from drive_bridge.ros.callback_guard import failures_of
from drive_bridge.ros.command_topics import CommandTopics
from drive_bridge.ros.errors import NodeParameterRefused, StartupError
from drive_bridge.ros.param_services import ParameterServices
from drive_bridge.ros.parameters import BridgeParameters, declare
from drive_bridge.ros.recording import RecordControl
from drive_bridge.ros.services import BridgeServices
from drive_bridge.ros.state_topics import StateTopics
from drive_bridge.ros.trajectory_action import TrajectoryAction

AUTO_ENABLE_TIMEOUT = 30.0


def config_source(params: BridgeParameters) -> ConfigSource:
    """Where the node (and its bus process) read the bus configuration."""
    return ConfigSource(path=params.config, text=params.config_yaml, base_dir=str(Path.cwd()),
                        sync_period=params.sync_period, simulate=params.simulate)


def load_config(params: BridgeParameters) -> BusConfig:
    """The bus configuration from the parameters, with the sync_period override applied."""
    try:
        return load(config_source(params))
    except ConfigError:
        raise
    except ValueError as exc:  # no configuration given
        raise StartupError(str(exc)) from None


class Bridge:
    """Everything one bus node does, for a plain or a lifecycle node: the master (and the
    simulated drives), state topics, commands, services and the trajectory action."""

    def __init__(self, node: Node, params: BridgeParameters, config: BusConfig) -> None:
        self.node = node
        self.params = params
        self.config = config
        self._held: set[str] = set()  # joints halted by deactivation (resumed by activation)
        self.bus_lost = threading.Event()  # the bus process is gone: the node exits (ros/main.py)
        self._closed = False
        for warning in config.warnings:
            node.get_logger().warning(f'configuration: {warning}')
        existing = _entities(node)
        self.master = BusClient(config, config_source(params), pvt_segment=params.pvt_segment,
                                pvt_lookahead=params.pvt_lookahead)
        self.master.add_event_listener(self._log_event)
        self.trajectories = self.master.executor
        try:  # before the bus opens: record.start records from the first frame
            self.recording = RecordControl(node, self.master, config, config_text(params, config))
        except BagError as exc:
            raise StartupError(str(exc)) from None
        try:
            ready = self.master.start()
        except (BusProcessStartError, DriveBridgeError) as exc:  # e.g. the interface cannot do what the config asks
            self.recording.close()
            raise StartupError(f'cannot start bus {config.bus.interface}:{config.bus.channel}: {exc}') from None
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
        self.master.add_lost_listener(self._on_bus_lost)
        self._entities = [e for e in _entities(node) if id(e) not in {id(x) for x in existing}]
        self.set_active(False)
        bus = config.bus
        sync = f'every {config.master.sync_period * 1000:.1f} ms' if config.master.sends_sync else 'off'
        node.get_logger().info(
            f'bus {bus.interface}:{bus.channel} open with {len(config.nodes)} node(s), '
            f'{len(self.master.axes)} joint(s); SYNC {sync}; '
            f'bus process {ready.pid}{"".join("; " + m for m in ready.messages)}')

    def _on_bus_lost(self, reason: str) -> None:
        """The bus process is gone: every joint unavailable at once, said on /diagnostics and
        ~/axis_states, commands refused with the reason; the node then exits (ros/main.py)."""
        if self.bus_lost.is_set():
            return
        self.bus_lost.set()
        self.node.get_logger().fatal(f'{reason}: every joint is unavailable; the drives stop by their '
                                     'heartbeat consumer; the node exits')
        self.state_topics.on_bus_lost()
        executor = self.node.executor
        if executor is not None:
            executor.wake()

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
        if self.master.lost:
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

    def abandon(self) -> None:
        """This process is dying (an unhandled exception): the bus process is left to stop every
        axis as for a lost node (``busproc.safestop``: at rest, then disabled or held), not asked
        to end; :meth:`close` then releases only this side (the recording is still closed)."""
        self.master.abandon()

    def close(self) -> None:
        """Stop motion safely and end the bus process (it releases the bus and the simulated
        drives). Idempotent."""
        if self._closed:
            return
        self._closed = True
        self.state_topics.active = self.command_topics.active = False
        if not self.master.lost and not self.master.abandoned:
            try:
                self.trajectories.stop(list(self.master.axes), 'bridge shutting down')
            except Exception as exc:  # the bus process stops every axis at its shutdown anyway
                self.node.get_logger().warning(f'stopping trajectories: {exc}')
        self.master.close()
        self.recording.close()  # after the bus: the bag has every frame the tap counted
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
    """The node's validated parameters (with the command line's config path) and bus
    configuration (StartupError says what is wrong)."""
    try:
        params = declare(node)
    except NodeParameterRefused as exc:
        raise StartupError(str(exc)) from None
    params = with_config_path(params, config_path)
    return params, configuration(params)


def with_config_path(params: BridgeParameters, config_path: str) -> BridgeParameters:
    """The configuration file named on the command line, unless a parameter names one."""
    if not params.config and not params.config_yaml and config_path:
        return dataclasses.replace(params, config=config_path)
    return params


def configuration(params: BridgeParameters) -> BusConfig:
    try:
        return load_config(params)
    except ConfigError as exc:
        raise StartupError(f'bus configuration refused:\n{exc}') from None
