"""Recording in the bridge: the ``record.*`` parameters, the ``~/record`` service, the
recording status in /diagnostics, and the tee that puts the decoded topics in the bag.

The frames come from the master's frame tap (:class:`drive_bridge.bag.recorder.Recorder`,
off the cycle thread); the decoded topics are the messages the node publishes, serialized
once more with ``rclpy.serialization`` and queued to the same recorder, so the bag has
both on one timeline (their ``header.stamp`` as log time). Bus events go in as
``rcl_interfaces/msg/Log`` on ``~/events``.
"""
from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from rcl_interfaces.msg import Log, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from std_srvs.srv import SetBool

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.recorder import Recorder, RecorderStats, config_files
from drive_bridge.busproc.client import BusClient
from drive_bridge.master.events import BusEvent, Level
from drive_bridge.model import BusConfig, RecordConfig
from drive_bridge.ros.diagnostics import PREFIX, _values

LOG_LEVELS = {Level.INFO: Log.INFO, Level.WARN: Log.WARN, Level.ERROR: Log.ERROR}


@dataclass(frozen=True)
class RecordParameters:
    path: str
    split_size_mb: float
    split_seconds: float
    start: bool


DESCRIPTIONS = {
    'path': 'directory of the bags; each recording is a new bag <channel>_<UTC time> in it',
    'split_size_mb': 'rotate to a new split at this size in MB (0 = no size limit)',
    'split_seconds': 'rotate to a new split after this many seconds (0 = no time limit)',
    'start': 'start recording when the node starts',
}


def declare_record(node: Node, defaults: RecordConfig) -> RecordParameters:
    """``record.*`` parameters; the bus config's ``record`` section gives their defaults."""
    values: dict[str, Any] = {}
    for name, description in DESCRIPTIONS.items():
        full = f'record.{name}'
        default = getattr(defaults, name)
        if node.has_parameter(full):  # a lifecycle node configured again
            value = node.get_parameter(full).value
        else:
            value = node.declare_parameter(full, default, ParameterDescriptor(description=description)).value
        values[name] = value
    return record_parameters(values)


def record_parameters(values: dict[str, Any]) -> RecordParameters:
    """Checked ``record.*`` values (BagError naming the parameter)."""
    try:
        params = RecordParameters(path=str(values['path']), split_size_mb=float(values['split_size_mb']),
                                  split_seconds=float(values['split_seconds']), start=bool(values['start']))
    except (TypeError, ValueError) as exc:
        raise BagError(f'parameters record.*: {exc}') from None
    for name, high in (('split_size_mb', 1e6), ('split_seconds', 86400.0)):
        value = getattr(params, name)
        if value < 0:
            raise BagError(f'parameter record.{name} must be >= 0, got {value}')
        if not math.isfinite(value) or value > high:  # 0 = no limit; a finite bound that means something
            raise BagError(f'parameter record.{name} must be a finite number in 0..{high:g} (0 = no limit), '
                           f'got {value}')
    if not params.path:
        raise BagError('parameter record.path must name a directory, got an empty string')
    return params


_TYPE_NAMES: dict[type, str] = {}


def type_name(msg: Any) -> str:
    """'sensor_msgs/msg/JointState' of an rclpy message."""
    cls = type(msg)
    name = _TYPE_NAMES.get(cls)
    if name is None:
        name = _TYPE_NAMES[cls] = f'{cls.__module__.split(".")[0]}/msg/{cls.__name__}'
    return name


def stamp_ns(msg: Any) -> int:
    stamp = msg.header.stamp if hasattr(msg, 'header') else msg.stamp
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


class RecordControl:
    """Starts and stops the recorder of one bus node."""

    def __init__(self, node: Node, master: BusClient, config: BusConfig, config_text: str | None) -> None:
        self.node = node
        self.master = master
        self.config = config
        self.config_text = config_text
        self.params = declare_record(node, config.record)
        self.recorder: Recorder | None = None
        self._listener: Any = None  # the bound method given to the tap, removed as the same object
        self.last: RecorderStats | None = None
        self._events_topic = f'{node.get_fully_qualified_name()}/events'
        master.add_event_listener(self.on_event)
        node.add_on_set_parameters_callback(self._on_set)
        node.add_post_set_parameters_callback(self._on_applied)
        if self.params.start:
            self.start()

    # -- record.* at run time: validated at once, used by the next recording --------------------------
    def _updated(self, parameters: Sequence[Parameter]) -> RecordParameters:
        values: dict[str, Any] = dataclasses.asdict(self.params)
        values.update({p.name.removeprefix('record.'): p.value for p in parameters if p.name.startswith('record.')})
        return record_parameters(values)

    def _on_set(self, parameters: Sequence[Parameter]) -> SetParametersResult:
        try:
            self._updated(parameters)
        except BagError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _on_applied(self, parameters: Sequence[Parameter]) -> None:
        if any(p.name.startswith('record.') for p in parameters):
            self.params = self._updated(parameters)

    def attach(self) -> None:
        """The service (once the node's other entities exist)."""
        self.node.create_service(SetBool, '~/record', self._on_service)

    # -- start / stop -----------------------------------------------------------------------------
    def start(self) -> Recorder:
        if self.recorder is not None:
            raise BagError(f'already recording to {self.recorder.path}')
        channel = str(self.config.bus.channel)
        base = Path(self.params.path).expanduser()
        name = f'{channel.replace("/", "_")}_{time.strftime("%Y%m%d_%H%M%S", time.gmtime())}'
        path = base / name
        suffix = 1
        while path.exists():
            path, suffix = base / f'{name}_{suffix}', suffix + 1
        split_bytes = round(self.params.split_size_mb * 1e6) or None
        since = self.master.frame_drops  # the boundary's count: this recording's share from now
        self.recorder = Recorder(path, channel=channel, split_bytes=split_bytes,
                                 split_seconds=self.params.split_seconds or None, config_yaml=self.config_text,
                                 files=config_files(self.config),
                                 upstream_drops=lambda: self.master.frame_drops - since)
        self._listener = self.recorder.on_frame
        self.master.add_frame_listener(self._listener)
        self.node.get_logger().info(f'recording to {path}')
        return self.recorder

    def stop(self) -> RecorderStats:
        recorder = self.recorder
        if recorder is None:
            raise BagError('not recording')
        self.master.remove_frame_listener(self._listener)
        self.recorder = self._listener = None
        self.last = stats = recorder.stop()
        self.node.get_logger().info(f'recording stopped: {stats.summary()}')
        return stats

    def close(self) -> None:
        if self.recorder is not None:
            self.stop()

    def _on_service(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        try:
            if request.data:
                response.message = str(self.start().path)
            else:
                response.message = self.stop().summary()
            response.success = True
        except BagError as exc:
            response.success, response.message = False, str(exc)
        return response

    # -- what goes in besides the frames (any thread) --------------------------------------------------
    def tee(self, topic: str, msg: Any) -> None:
        """A message the node just published: into the bag, stamped with its header (serialized
        in the recorder's writer thread, not in the publishing one)."""
        recorder = self.recorder
        if recorder is not None:
            recorder.add_message(topic, type_name(msg), stamp_ns(msg), msg, serialize_message)

    def on_event(self, event: BusEvent) -> None:
        recorder = self.recorder
        if recorder is None:
            return
        now = round(event.timestamp * 1e9)
        log = Log(level=LOG_LEVELS[event.level], name=event.node_name or 'bus', msg=event.message,
                  function=event.kind.value, file='', line=event.node_id)
        log.stamp.sec, log.stamp.nanosec = divmod(now, 1_000_000_000)
        recorder.add_message(self._events_topic, 'rcl_interfaces/msg/Log', now, log, serialize_message)

    def status(self) -> DiagnosticStatus:
        """The recording's line in /diagnostics."""
        status = DiagnosticStatus(name=f'{PREFIX}: recording', hardware_id=f'can {self.config.bus.channel}')
        stats = self.recorder.stats() if self.recorder is not None else self.last
        if stats is None:
            status.level, status.message = DiagnosticStatus.OK, 'not recording'
            status.values = _values(recording=False)
            return status
        recording = self.recorder is not None
        status.values = _values(recording=recording, path=stats.path, frames=stats.frames, messages=stats.messages,
                                dropped=stats.dropped, dropped_upstream=stats.dropped_upstream, queued=stats.queued,
                                bytes=stats.bytes, split=stats.split,
                                closed_splits=stats.splits, error=stats.error)
        if stats.error:
            status.level, status.message = DiagnosticStatus.ERROR, f'recording failed: {stats.error}'
        elif stats.dropped or stats.dropped_upstream:
            status.level, status.message = DiagnosticStatus.WARN, (
                f'{stats.dropped + stats.dropped_upstream} frames/messages dropped '
                f'({stats.dropped_upstream} before the recorder, in the bus process)')
        else:
            status.level = DiagnosticStatus.OK
            status.message = f'recording to {stats.path}' if recording else f'stopped; last bag {stats.path}'
        return status
