"""What the diagnosis knows beside the frames: the bus config (given, or stored in the bag
with its EDS/DCF files) and EDS files per node (``--eds NODE=FILE``)."""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from drive_bridge.bag.diagnose.errors import DiagnoseError
from drive_bridge.bag.diagnose.model import Context, NodeInfo
from drive_bridge.errors import DriveBridgeError

if TYPE_CHECKING:  # the config loader, EDS parser and families are imported only when a config or EDS is given
    from drive_bridge.bag.source import Recording
    from drive_bridge.model import BusConfig


@dataclass
class DiagnoseInputs:
    config: BusConfig | None = None
    config_source: str = ''
    eds: dict[int, Path] = field(default_factory=dict)
    bitrate: int | None = None

    def eds_names(self) -> dict[int, str]:
        """Per node, the EDS/DCF the diagnosis names objects from: --eds, else the config's (stored in the bag)."""
        out: dict[int, str] = {}
        if self.config is not None:
            stored = self.config_source.startswith('stored')
            for node in self.config.nodes:
                if node.eds_path is not None:
                    out[node.node_id] = f'{node.eds_path.name}' + (' (stored in the bag)' if stored else '')
        out.update({node: str(path) for node, path in self.eds.items()})
        return out


def parse_eds_args(items: Sequence[str]) -> dict[int, Path]:
    """``NODE=FILE`` pairs; DiagnoseError naming the bad one."""
    out: dict[int, Path] = {}
    for item in items:
        node, sep, file = item.partition('=')
        try:
            node_id = int(node, 0)
        except ValueError:
            node_id = 0
        if not sep or not file or not 1 <= node_id <= 127:
            raise DiagnoseError(f'--eds {item!r}: expected NODE=FILE with a node id 1..127 (e.g. 3=drive.eds)')
        out[node_id] = Path(file)
    return out


def load_inputs(recording: Recording, config: Path | None = None, eds: Mapping[int, Path] | None = None,
                bitrate: int | None = None) -> DiagnoseInputs:
    inputs = DiagnoseInputs(eds=dict(eds or {}), bitrate=bitrate)
    try:
        if config is not None:
            if not config.exists():
                raise DiagnoseError(f'{config}: no such config file')
            from drive_bridge.config.loader import load_bus_config
            inputs.config = load_bus_config(config)
            inputs.config_source = str(config)
        elif recording.config_yaml:
            from drive_bridge.bag.stored import load_stored_config
            inputs.config = load_stored_config(recording.config_yaml, recording.files,
                                               f'{recording.path} (stored config)')
            inputs.config_source = f'stored in {recording.path.name}'
    except DiagnoseError:
        raise
    except DriveBridgeError as exc:
        raise DiagnoseError(f'config {config or "stored in the bag"}: {exc}') from exc
    for node, path in inputs.eds.items():
        if not path.exists():
            raise DiagnoseError(f'--eds {node}={path}: no such file')
    return inputs


def context_for(inputs: DiagnoseInputs) -> Context:
    ctx = Context()
    config = inputs.config
    if config is not None:
        from drive_bridge.families.registry import get_family
        ctx.bitrate = config.bus.bitrate
        ctx.master = config.master.node_id
        ctx.sync_period = config.master.sync_period if config.master.sends_sync else None
        for node in config.nodes:
            ctx.nodes[node.node_id] = NodeInfo(
                node.node_id, node.name, get_family(node.family), node.od,
                joints={axis.slot: axis.joint for axis in node.axes},
                heartbeat_ms=node.heartbeat_producer_ms if not node.guarding else 0,
                guard_time_ms=node.guard_time_ms,
                position_factor={axis.slot: axis.scaling.position_factor for axis in node.axes},
                following_limit={axis.slot: axis.position_loop.following_error for axis in node.axes
                                 if axis.position_loop.following_error})
    for node_id, path in inputs.eds.items():
        from drive_bridge.config.eds import load_object_dictionary
        try:
            od = load_object_dictionary(path, node_id)
        except DriveBridgeError as exc:
            raise DiagnoseError(f'--eds {node_id}={path}: {exc}') from exc
        ctx.node(node_id).od = od
    if inputs.bitrate:
        ctx.bitrate = inputs.bitrate
    return ctx
