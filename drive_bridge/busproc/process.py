"""The bus process: ``python -m drive_bridge.busproc --lanes STOP,REQUEST,STATE``, started by
the node process (:mod:`.client`) with the three lanes' file descriptors.

It loads the configuration the node names (``intents.Start``, the first message), starts the
simulated drives when the configuration asks for them (on its ``virtual`` bus, in this
process), the Master and the trajectory executor, and serves the node until:
- the node asks it to end (``Shutdown``): the Master stops (enabled axes quick-stopped), exit 0;
- the node is gone (a lane closed): :mod:`.safestop`, then exit 0 — unless an axis holds
  (``on_node_loss: hold``): then the bus keeps running, holding it, until SIGTERM;
- SIGTERM: as if the node were gone. SIGINT is ignored: a terminal's Ctrl-C reaches the whole
  process group, and the node decides (it asks for a shutdown).
It never imports rclpy.
"""
from __future__ import annotations

import argparse
import gc
import logging
import os
import signal
import socket
import sys
import threading

from drive_bridge.busproc import wire
from drive_bridge.busproc.intents import Start
from drive_bridge.busproc.reports import Farewell, Ready, StartFailed
from drive_bridge.busproc.safestop import family_stops, stop_all
from drive_bridge.busproc.server import BusServer
from drive_bridge.config.source import load
from drive_bridge.errors import DriveBridgeError
from drive_bridge.master.master import Master
from drive_bridge.streaming.executor import TrajectoryExecutor

log = logging.getLogger('drive_bridge.busproc')


class BusProcess:
    def __init__(self, stop_lane: wire.Lane, request_lane: wire.Lane, state_lane: wire.Lane) -> None:
        self.stop_lane, self.request_lane, self.state_lane = stop_lane, request_lane, state_lane
        self.done = threading.Event()
        self.exit_code = 0
        self.master: Master | None = None
        self.server: BusServer | None = None
        self.simulation: object | None = None
        self._ending = threading.Lock()
        self.terminated = threading.Event()  # SIGTERM came

    def run(self) -> int:
        start = self.request_lane.recv()
        if not isinstance(start, Start):
            log.error('bus process: the first message is not a Start (%s)', type(start).__name__)
            return 2
        try:
            self._start(start)
        except Exception as exc:  # the node reports it and exits
            text = str(exc) if isinstance(exc, DriveBridgeError | ValueError) else f'{type(exc).__name__}: {exc}'
            self._release()
            try:
                self.request_lane.send(StartFailed(text))
            except OSError:
                pass
            return 2
        self.done.wait()
        return self.exit_code

    def _start(self, start: Start) -> None:
        config = load(start.source)
        logging.basicConfig(level=logging.WARNING, format=f'[bus {config.bus.channel}] %(levelname)s %(message)s')
        logging.getLogger('drive_bridge').setLevel(logging.INFO)
        messages = []
        if config.simulation.enabled:
            from drive_bridge.sim import SimulatedBus  # the simulated drives share this process's virtual bus
            self.simulation = simulation = SimulatedBus(config)
            simulation.start()
            messages.append('simulated drives in the bus process')
        self.master = master = Master(config)
        self.server = server = BusServer(master, self.stop_lane, self.request_lane, self.state_lane,
                                         on_lost=self.node_lost, on_shutdown=self.shutdown)
        server.outbox.forward_frames = start.frames  # from the first frame: the node may record the boot
        master.start()
        executor = TrajectoryExecutor(master.axes, cycle_period=config.master.cycle_period,
                                      pvt_segment=start.pvt_segment, pvt_lookahead=start.pvt_lookahead,
                                      scale_to_limits=config.trajectory.scale_to_limits)
        master.add_cycle_listener(executor.check)
        master.add_emcy_listener(executor.on_emcy, safety=True)
        server.start(executor)
        # the configuration, the object dictionaries and the simulated drives never become garbage:
        # keep full collections from walking them, which would stall the cycle (the GIL is held)
        gc.collect()
        gc.freeze()
        self.request_lane.send(Ready(os.getpid(), tuple(master.axes), tuple(messages)))

    # -- ends ---------------------------------------------------------------------------------------
    def shutdown(self, reason: str) -> None:
        """The node asks: stop motion, release the bus, exit 0."""
        threading.Thread(target=self._end, args=(reason, True), name='drive_bridge-shutdown', daemon=True).start()

    def node_lost(self, reason: str) -> None:
        """The node is gone (or SIGTERM): stop every axis in a controlled way (safestop)."""
        self._end(f'node process lost: {reason}', False)

    def _end(self, reason: str, asked: bool) -> None:
        if not self._ending.acquire(blocking=False):
            return
        master, server = self.master, self.server
        if not asked and master is not None and server is not None:
            log.error('%s: stopping every enabled axis', reason)
            lines = stop_all(master.axes, server.executor, reason, family_stops(master.nodes.values()))
            for line in lines:
                log.warning('%s', line)
            if any('held in quick stop active' in line for line in lines):
                log.warning('axes held (on_node_loss: hold): the bus keeps running until this process '
                            'gets SIGTERM (pid %d)', os.getpid())
                self._wait_for_sigterm()
        if server is not None and master is not None and asked:
            try:  # the bus stopped first: its last counts go with the farewell
                master.stop()
                server.outbox.put(Farewell(reason, master.snapshot()))
            except Exception as exc:
                log.warning('farewell: %r', exc)
        self._release()
        self.done.set()

    def _wait_for_sigterm(self) -> None:
        self.terminated.wait()

    def on_sigterm(self) -> None:
        """SIGTERM (main thread): as if the node were gone; while axes are held, the end of the hold."""
        self.terminated.set()
        threading.Thread(target=self.node_lost, args=('SIGTERM',), daemon=True).start()

    def _release(self) -> None:
        if self.master is not None:
            self.master.stop()
        if self.server is not None:
            self.server.close()
        simulation = self.simulation
        if simulation is not None:
            simulation.stop()  # type: ignore[attr-defined]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='python -m drive_bridge.busproc', description=__doc__)
    parser.add_argument('--lanes', required=True, help='file descriptors of the stop, request and state lanes')
    args = parser.parse_args(argv)
    fds = [int(fd) for fd in args.lanes.split(',')]
    lanes = [wire.Lane(socket.socket(fileno=fd)) for fd in fds]
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    process = BusProcess(*lanes)

    signal.signal(signal.SIGTERM, lambda _signum, _frame: process.on_sigterm())
    code = process.run()
    for lane in lanes:
        lane.close()
    sys.stdout.flush()
    return code
