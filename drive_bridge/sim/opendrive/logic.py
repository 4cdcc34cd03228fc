"""The OPEN drive's logic input functions and their channels (appendix §2.6.8, "Funzioni logiche
di ingresso"; opendrive.md §3.6).

Functions are numbered as the appendix names them: the standard functions I00..I28 and the
application functions I29..I63. Each terminal input n (1..8) controls the function in connection
Cn (C1..C8, 0..63).

- Standard functions: the fieldbus channel is 0x2016[k] / 0x201F bit k (one state), read back in
  0x2010[k] / 0x2021 bit k. RUN (I00) is the AND of the terminal, fieldbus and serial channels (a
  function no terminal controls counts as high in the AND; life guarding may force it low), every
  other one the OR of the channels. 0x201F has 32 bits: bits 29..31 (no I29..I31 among the
  standard functions) are reached by the fieldbus and serial channels only.
- Application functions: "can be forced over CAN (0x2020, bit b = I(29 + b)); where one is also
  assigned to a terminal input, the physical state imposes the function's state" (Qualora
  qualcuna delle funzioni sia associata anche ad un ingresso fisico in morsettiera, lo stato
  logico fisico imporrà lo stato della funzione corrispondente): 0x2022 bit b is the terminal's
  state (the OR of its terminals) where one is assigned, else 0x2020 bit b. I61..I63 are beyond
  the 32-bit words: a terminal controls them, CAN sees nothing of them.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

RUN = 0  # I00 "marcia"
STANDARD_FUNCTIONS = 32  # bits of 0x201F / 0x2021
LAST_STANDARD = 28  # I28: the last standard function a terminal may control
FIRST_APPLICATION = 29  # I29 = bit 0 of 0x2020 / 0x2022
APPLICATION_BITS = 32  # I29..I60
LAST_FUNCTION = 63  # I63
TERMINAL_INPUTS = 8
TERMINAL_CONNECTIONS = range(1, TERMINAL_INPUTS + 1)  # C1..C8


class LogicInputs:
    """Channels and resulting state of the logic input functions (module docstring)."""

    def __init__(self, connections: Callable[[], Sequence[int]], terminal_run: bool) -> None:
        self._connections = connections  # Tab_con: C1..C8 at elements 1..8
        self.terminals = 1 if terminal_run else 0  # bit n-1: terminal input n
        self.serial = 1 << RUN  # serial channel: RUN high, the rest low
        self.fieldbus = 1 << RUN
        self.application = 0  # 0x2020 as written
        self.guard_stop = False  # life guarding forces RUN low
        self.standard = 0  # 0x2021
        self.application_state = 0  # 0x2022
        self.compute()

    def reset(self) -> None:
        """Power-on / reset node: fieldbus RUN high (Tab_inp_dig_field[0] = high), the rest low."""
        self.fieldbus = 1 << RUN
        self.application = 0
        self.guard_stop = False
        self.compute()

    def terminal_channel(self, function: int) -> bool | None:
        """OR of the terminal inputs assigned to ``function`` (None: no terminal controls it)."""
        connections = self._connections()
        state: bool | None = None
        for n in TERMINAL_CONNECTIONS:
            if connections[n] == function:
                state = bool(state) or bool(self.terminals >> (n - 1) & 1)
        return state

    def terminals_of(self, function: int) -> list[int]:
        connections = self._connections()
        return [n for n in TERMINAL_CONNECTIONS if connections[n] == function]

    def compute(self) -> None:
        word = 0
        for function in range(STANDARD_FUNCTIONS):
            terminal = self.terminal_channel(function) if function <= LAST_STANDARD else None
            fieldbus, serial = bool(self.fieldbus >> function & 1), bool(self.serial >> function & 1)
            if function == RUN:  # AND of the channels (no terminal: high)
                on = (terminal is None or terminal) and fieldbus and serial and not self.guard_stop
            else:  # OR of the channels
                on = bool(terminal) or fieldbus or serial
            word |= int(on) << function
        self.standard = word
        application = 0
        for bit in range(APPLICATION_BITS):
            terminal = self.terminal_channel(FIRST_APPLICATION + bit)
            on = terminal if terminal is not None else bool(self.application >> bit & 1)
            application |= int(on) << bit
        self.application_state = application

    def set_terminal(self, number: int, on: bool) -> None:
        if not 1 <= number <= TERMINAL_INPUTS:
            raise ValueError(f'terminal input {number}: the drive has 1..{TERMINAL_INPUTS}')
        bit = 1 << (number - 1)
        self.terminals = self.terminals | bit if on else self.terminals & ~bit

    def set_serial(self, function: int, on: bool) -> None:
        if not 0 <= function < STANDARD_FUNCTIONS:
            raise ValueError(f'logic function {function}: the drive has 0..{STANDARD_FUNCTIONS - 1}')
        bit = 1 << function
        self.serial = self.serial | bit if on else self.serial & ~bit

    def set_fieldbus_function(self, function: int, value: int) -> None:
        bit = 1 << function
        self.fieldbus = self.fieldbus | bit if value else self.fieldbus & ~bit
