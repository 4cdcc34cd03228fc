"""SimulatedBus: every node of a bus configuration as a simulated device on the
config's ``virtual`` channel, sharing one canopen Network (one Notifier thread).

The bridge reaches these devices only through CAN frames on that channel; tests may
inspect them through :meth:`SimulatedBus.drive`.
"""
from __future__ import annotations

import can
import canopen

from drive_bridge.model import BusConfig
from drive_bridge.sim.registry import simulator_for
from drive_bridge.sim.slave import NOTIFIER_CYCLE, SimulatedSlave


class SimulatedBus:
    """Simulators for all nodes of ``config``; ``start()`` powers them on, ``stop()``
    powers off and disconnects (no thread left). Also a context manager."""

    def __init__(self, config: BusConfig, bus: can.BusABC | None = None) -> None:
        # ``bus``: an open bus of any interface to use instead of the config's virtual
        # channel (``drive-bridge sim``); it is shut down by stop()
        self._bus = bus
        if bus is None and config.bus.interface != 'virtual':
            raise ValueError(f'simulated drives need the python-can "virtual" interface, '
                             f'not {config.bus.interface!r}')
        names = {node.name for node in config.nodes}
        stray = sorted(set(config.simulation.options) - names)
        if stray:
            raise ValueError(f'simulation options for unknown node {stray[0]!r}; nodes: {", ".join(sorted(names))}')
        self.config = config
        self.network: canopen.Network | None = None
        self.drives: dict[int, SimulatedSlave] = {}
        for node in config.nodes:
            cls = simulator_for(node.family)
            self.drives[node.node_id] = cls(node, options=config.simulation.options.get(node.name, {}))

    @property
    def running(self) -> bool:
        return self.network is not None

    def start(self) -> SimulatedBus:
        """Connect to the virtual channel and power every node on (boot-up frames follow)."""
        if self.network is not None:
            return self
        network = canopen.Network(self._bus)
        network.NOTIFIER_CYCLE = NOTIFIER_CYCLE
        if self._bus is not None:
            network.connect()
        else:
            network.connect(interface='virtual', channel=self.config.bus.channel, receive_own_messages=False)
        self.network = network
        try:
            for drive in self.drives.values():
                drive.attach(network)
            for drive in self.drives.values():
                drive.power_on()
        except Exception:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        """Power off every node, leave the bus and stop the Notifier. Idempotent."""
        for drive in self.drives.values():
            drive.power_off()
            drive.detach()
        network, self.network = self.network, None
        if network is not None:
            network.disconnect()

    def drive(self, node: int | str) -> SimulatedSlave:
        """The simulator of a node, by node id or by name."""
        if isinstance(node, int) and node in self.drives:
            return self.drives[node]
        for drive in self.drives.values():
            if drive.name == node:
                return drive
        known = ', '.join(f'{d.name} ({d.node_id})' for d in self.drives.values())
        raise KeyError(f'no simulated node {node!r}; nodes: {known}')

    def __enter__(self) -> SimulatedBus:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
