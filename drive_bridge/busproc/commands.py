"""Direct commands to the bus process, latest value wins: a client may publish 10,000 commands
a second, and the cycle takes one per joint and cycle anyway. The node keeps the newest
command per topic and joint set and sends what is pending at most once per cycle period, so
the bus process handles at most a few command messages per cycle, whatever a client sends."""
from __future__ import annotations

import threading

from drive_bridge.busproc.intents import DirectCommands, JointCommand
from drive_bridge.busproc.ports import CommandClient


class CommandSender:
    def __init__(self, client: CommandClient, period: float) -> None:
        self.client = client
        self.period = period
        self.sent = 0
        self.coalesced = 0  # commands replaced by a newer one before they were sent
        self._pending: dict[tuple[str, frozenset[str]], DirectCommands] = {}
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name='drive_bridge-commands', daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()

    def submit(self, topic: str, commands: tuple[JointCommand, ...]) -> None:
        """Queue one message's commands (checked whole in the bus process; a refusal comes back
        to the client's refusal listeners)."""
        key = (topic, frozenset(c.joint for c in commands))
        with self._lock:
            if key in self._pending:
                self.coalesced += 1
            self._pending[key] = DirectCommands(topic, commands)
        self._wake.set()

    def _run(self) -> None:
        while not self._stop.is_set():
            self._wake.wait()
            self._wake.clear()
            with self._lock:
                pending, self._pending = list(self._pending.values()), {}
            for body in pending:
                if self.client.lost:
                    break
                try:
                    self.client.post(body)  # answered by CommandRefused only when refused
                except Exception:  # the bus process is gone: the client reports that
                    break
                self.sent += 1
            self._stop.wait(self.period)
