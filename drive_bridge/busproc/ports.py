"""What the node process's parts need of :class:`~.client.BusClient`, each as a protocol that
names only what the part calls (``XClient``: the client as X sees it).

The client builds its parts (the trajectory executor's stand-in, the snapshot cache, the
direct-command sender, the axes' stand-ins) and hands each itself. Typed as ``BusClient``, each
part would import the module that builds it: these protocols keep the imports one way
(client -> parts -> ports) and say what a part may ask of the client, and so what a test's fake
must answer. The axes' own one, :class:`~.proxies.AxisClient`, is beside :class:`~.proxies.AxisProxy`,
which this module names.
"""
from __future__ import annotations

import concurrent.futures
from collections.abc import Mapping
from typing import Protocol

from drive_bridge.busproc.intents import Stop
from drive_bridge.busproc.proxies import AxisProxy, NodeProxy
from drive_bridge.master.master import BusSnapshot
from drive_bridge.model import BusConfig


class CommandClient(Protocol):
    """The direct-command sender's: post a command (answered only when refused) while the bus
    process runs."""

    @property
    def lost(self) -> str: ...

    def post(self, body: object) -> None: ...


class RequestClient(Protocol):
    """The request lane, called as an rclpy service client is: ``call`` waits for the answer,
    ``call_async`` returns its future; ``lost`` says why the bus process is gone ('' while it runs)."""

    @property
    def lost(self) -> str: ...

    def call(self, body: object, timeout: float | None = None) -> object: ...

    def call_async(self, body: object) -> concurrent.futures.Future[object]: ...


class ExecutorClient(RequestClient, Protocol):
    """The trajectory executor's: requests, the stop lane, its settings, and each joint's stream
    strategy."""

    @property
    def axes(self) -> Mapping[str, AxisProxy]: ...

    def stop(self, body: Stop) -> concurrent.futures.Future[object]: ...

    def settings(self, **changes: object) -> None: ...


class SnapshotClient(RequestClient, Protocol):
    """The snapshot cache's: requests, and what it builds ``Master.snapshot()``'s stand-in from
    (the configuration, the nodes and axes, the bus process's last word)."""

    @property
    def config(self) -> BusConfig: ...

    @property
    def nodes(self) -> Mapping[str, NodeProxy]: ...

    @property
    def axes(self) -> Mapping[str, AxisProxy]: ...

    @property
    def final(self) -> BusSnapshot | None: ...
