"""Where a drive family's CiA 402 drive differs from the profile: :class:`AxisQuirks`, handed to
the :class:`~drive_bridge.cia402.axis.Axis` by the family (its per-node part, ``FamilyNode.axis_quirks``).
Each hook's default is plain CiA 402, so a family overrides only what its manual says differs.

A hook reaches its axis only through :class:`AxisPort` (``self.axis``, set by :meth:`attach`):
its objects, its intents, its state and configuration, a wait for a condition. The axis' own
members stay its own.

| hook | what for | default |
|---|---|---|
| ``attach`` | the axis is built: add the family's object keys | remember the axis |
| ``state_of`` | the device state a statusword shows (a fault the statusword cannot show) | CiA 402's table |
| ``fault_pending`` | a fault the statusword bits do not show (snapshot ``fault``) | False |
| ``fault_hold`` | the controlword that holds a faulted drive (then reset bit added on the edge) | None: CiA 402's |
| ``reset_fault`` | how a fault is cleared | rising edge of the profile's reset bit |
| ``outputs`` | what one output write becomes (drop it, convert it, add an object) | the write itself |
| ``cycle_targets`` | this cycle's targets, as decided for the mode | unchanged |
| ``setpoint_refusal`` | a streamed set-point the drive must never get ('' to apply it) | '' |
| ``check_command`` | a direct command the family checks itself (True) | False: CiA 402's checks |
| ``commanded_position`` | the position target last sent, device units | None: the written target |
| ``stop_deceleration`` | the family's deceleration for a controlled stop, SI | None: the configured or 0x6084 |
| ``check_trajectory`` | refuse a trajectory the drive cannot follow (raise AxisError) | accept |
| ``parse_mode``, ``command_field`` | the family's mode names; what a direct command carries | CiA 402's |
| ``before_mode_change`` | refuse a mode change (raise), or False: nothing to do | True |
| ``on_node_reset`` | the node was configured again (under the axis' lock) | nothing |

Units read at boot are the family's: it applies them through ``self.axis.update_config``.
"""
from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Protocol

from drive_bridge.cia402 import statemachine as sm
from drive_bridge.cia402.modes import POSITION_MODES, TORQUE_MODES, VELOCITY_MODES, parse_mode
from drive_bridge.cia402.profile import FaultModel
from drive_bridge.cia402.statemachine import State
from drive_bridge.joint import NodeIo, Setpoint
from drive_bridge.joint.intents import Intents
from drive_bridge.model import AxisConfig, Timeouts

Output = tuple[str, int | float]  # (key name, value)


class AxisPort(Protocol):
    """What the quirks may use of their axis: objects by key name, intents, state, config, waits."""

    node: NodeIo
    key: dict[str, tuple[int, int]]  # key name -> (index, subindex); the quirks may add their own
    config: AxisConfig
    timeouts: Timeouts
    cycle_period: float
    intents: Intents
    fault_model: FaultModel

    @property
    def lock(self) -> threading.Condition:
        """The axis' lock: held around every cycle and intent; notified on new inputs."""

    @property
    def mode(self) -> int: ...

    @property
    def state(self) -> State: ...

    def read(self, name: str) -> int | float | None:
        """The newest value of a key name (PDO or SDO-polled)."""

    def where(self) -> str:
        """'axis ... (node ..., slot ...)': how messages name the axis."""

    def wait(self, done: Callable[[], bool], timeout: float, what: str) -> None:
        """Wait until ``done()`` (checked on each input), else AxisError naming ``what``."""

    def require_available(self) -> None: ...
    def fault_text(self) -> str: ...
    def way_out(self) -> str: ...
    def check_limits(self, position: float | None, velocity: float | None, effort: float | None) -> None: ...

    def update_config(self, config: AxisConfig) -> None:
        """A new configuration (units read at boot: scaling, limits); the stop deceleration is derived again."""

    def say(self, message: str) -> None:
        """The axis' message (its snapshot's ``message``)."""

    def reset_by_edge(self, bit: int, timeout: float | None, done: Callable[[], bool] | None = None,
                      what: str = 'fault reset (leaving FAULT)',
                      failed: Callable[[], str] = lambda: 'the cause is still present') -> None:
        """The fault reset: a rising edge of controlword ``bit``, waited for until ``done()``
        (default: the state leaves FAULT); the EMCYs before it no longer explain a fault."""


class AxisQuirks:
    """Plain CiA 402: every hook is the profile's behaviour (see the module's table)."""

    axis: AxisPort

    def attach(self, axis: AxisPort) -> None:
        """The axis these quirks serve is built (its keys exist; its node may not be booted)."""
        self.axis = axis

    def state_of(self, statusword: int) -> State:
        return sm.state_from_statusword(statusword)

    def fault_pending(self) -> bool:
        return False

    def fault_hold(self, state: State) -> int | None:
        return None

    def reset_fault(self, timeout: float | None) -> None:
        self.axis.reset_by_edge(self.axis.fault_model.reset_bit, timeout)

    def outputs(self, name: str, value: int | float) -> Sequence[Output]:
        return ((name, value),)

    def cycle_targets(self, state: State, targets: dict[str, int]) -> dict[str, int]:
        return targets

    def setpoint_refusal(self, setpoint: Setpoint) -> str:
        return ''

    def check_command(self, position: float | None, velocity: float | None, effort: float | None) -> bool:
        return False

    def commanded_position(self) -> int | None:
        return None

    def stop_deceleration(self) -> float | None:
        return None

    def check_trajectory(self, has_positions: bool, has_velocities: bool) -> None:
        return None

    def parse_mode(self, mode: int | str) -> int:
        return parse_mode(mode)

    def command_field(self, mode: int) -> str | None:
        return ('position' if mode in POSITION_MODES else 'velocity' if mode in VELOCITY_MODES
                else 'effort' if mode in TORQUE_MODES else None)

    def before_mode_change(self, code: int) -> bool:
        return True

    def on_node_reset(self) -> None:
        return None
