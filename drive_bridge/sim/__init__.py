"""Simulated CANopen devices: real slaves on a python-can ``virtual`` bus.

The bridge reaches them only through CAN frames; tests may inspect their state.

- :class:`SimulatedBus` -- every node of a :class:`~drive_bridge.model.BusConfig`
- :class:`SimulatedSlave` -- a CiA 301 node (family ``generic_301``)
- :class:`SimDrive402` -- a CiA 402 drive with 1..N axes (family ``generic_402``)
- :class:`SimAkd` -- a Kollmorgen AKD with PVT interpolation and the AKD's quirks (family ``akd``)
- :class:`SimOpenDrive` -- an OPEN drive: CiA 301 only, logic functions, alarms, P/C parameters (family ``opendrive``)
- :class:`SimS120` -- a SINAMICS S120 + CBC10: drive objects, p8630 window, SINAMICS EMCY (family ``sinamics_s120``)
- :class:`SimServostar` -- a SERVOSTAR 400/600: boot EMCY, PDO library, mode 0xFA, no Fault state (family ``servostar``)
- :func:`simulator_for` / :func:`register_simulator` -- family name -> simulator class
- :mod:`drive_bridge.sim.testing` -- test-side master helpers (SimBench, FrameLog, SyncLoop)
- ``python -m drive_bridge.sim.bench`` -- per-SYNC cost of one simulated drive

Modules: slave (CiA 301 node), sdo (SDO server access), pdo (PDO engine), pdocodec (a
PDO's mapping to bytes and back), pdoparams (CiA 301 rules of PDO parameter writes), nmt (NMT
states, heartbeat consumer), guarding (node guarding, life guarding), commobjects
(CiA 301 write rules of the communication objects), emcy (EMCY, 0x1001, 0x1003),
store (typed OD values), timers (per-slave clock thread), synccost (SYNC handling
time), faults (fault-injection switches), options (simulation options), interfaces
(what a mode uses of its axis, an axis of its drive), axis402 (the 402 axis), its parts
devicecontrol (402 state machine, stop ramps, statusword) and controlloop (model step,
following error), axisparams (derived motion parameters), opmodes (modes of operation:
opmode, profilemodes, homingmode, cyclicmodes), ipbuffer (IP buffer), motion (pure motion
model), drive402, akd/ (Kollmorgen AKD package), ascii_channel (the AKD's ASCII channel),
registry, bus.

A family's simulator subclasses SimulatedSlave / SimDrive402 / Axis402 / PdoEngine and
overrides the hooks their docstrings list; it never needs their private methods.
"""
from drive_bridge.sim.akd import SimAkd  # registers the 'akd' family's simulator
from drive_bridge.sim.axis402 import Axis402
from drive_bridge.sim.bus import SimulatedBus
from drive_bridge.sim.drive402 import SimDrive402
from drive_bridge.sim.opendrive import SimOpenDrive  # registers the 'opendrive' family's simulator
from drive_bridge.sim.options import AXIS_OPTIONS, SLAVE_OPTIONS
from drive_bridge.sim.registry import register_simulator, simulated_families, simulator_for
from drive_bridge.sim.s120 import SimS120  # registers the 'sinamics_s120' family's simulator
from drive_bridge.sim.servostar import SimServostar  # registers the 'servostar' family's simulator
from drive_bridge.sim.slave import SimulatedSlave

__all__ = ['AXIS_OPTIONS', 'Axis402', 'SLAVE_OPTIONS', 'SimAkd', 'SimDrive402', 'SimOpenDrive', 'SimS120',
           'SimServostar', 'SimulatedBus',
           'SimulatedSlave',
           'register_simulator', 'simulated_families', 'simulator_for']
