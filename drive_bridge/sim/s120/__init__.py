"""A simulated SINAMICS S120 (CU320-2 with the CBC10 CANopen board, firmware 4.7), family
``sinamics_s120``, after shared/drives/sinamics-s120-cbc10.md (section numbers in brackets;
[B] marks background the manual does not give, chosen here).

Modules: objects (indices, numbers, codes), parameters (the SINAMICS parameter table), emcy
(messages, EMCY layout, 0x1003 per module), pdo (PDO rules), modes (VL / PV / PT), axis (a
motor drive object), options, dictionary (the object dictionary as built), window (the
parameter window p8630), storage (0x1010 / 0x1011), telegram (A08751), messages (the active
faults and alarms), view (a drive object's snapshot), drive (the node: :class:`SimS120`,
registered on import, composed of those parts).

The object dictionary is the node config's EDS, as for every simulated slave; a modular EDS
must come expanded for the configured slots (the family's ``prepare_object_dictionary``). What
the EDS lacks and the drive has, the simulator adds: the parameter window 0x2000 + number.

Structure [1.4]
    One node = one Control Unit (drive object 1) with ``drive_objects`` motor drive objects
    (default: every axis slot of the OD, 0x6040 + 0x800 k). Slot k is drive object
    ``do_numbers[k]`` (p8743[k]; default 2 + k); CiA 402 objects at +0x800, PDO parameters at
    +0x40 per slot. Only slot 0's PDOs keep the EDS's predefined COB-IDs; the others start
    invalid (bit 31 set). ``predefined_mapping``: PDO 1..4 of a slot whose mapping the EDS
    leaves empty (the flat file) get the Predefined Connection Set's mapping (Tab. 2-3/2-4).

NMT [2.1, 2.10]
    Boot-up frame (0x700 + id, one byte 0), then the state of p8684 (option ``p8684``: 127
    pre-operational, 5 operational, 4 stopped), after power-on, reset node and reset
    communication; SDO only in pre-operational and operational. p0009 from non-zero to 0
    reboots the Control Unit after ``reboot_delay`` s: as a power-on (boot-up frame again, the
    saved parameters loaded, p8630 back to 0, p0009 = 0). NMT reset node resets the CANopen
    objects to their stored values but keeps the SINAMICS parameters (they are the drive's RAM,
    not CANopen objects), reset communication resets 0x1000..0x1FFF.

Modes, units, ramps [4, 5, 7] (axis, modes)
    VL (2), PV (3), PT (4) only; 0x6060 accepts every INTEGER8 and reads back what was
    written; the mode changes at the drive's next cycle when it is one of the three, else the
    old one stays; 0x6061 shows the mode in effect; 0x6502 = VL | PV | PT (VL only if the OD
    has 0x6042). Mode at power-on: option ``mode``. Speeds ramp with p1120 / p1121 (0 to
    p1082), OFF3 with p1135; 0x6083 / 0x6084 / 0x6085 = p1082 / ramp time, 0x6046 / 0x6048 and
    0x6072 mirror p1080, p1082, p1120, p1520. Velocity objects in increments/s (p0408 x
    2^p0418 per revolution, read at boot) with ``encoder``, in rpm without; torque in per mille
    of r0333; position actual 0x6063 (r0482), no 0x6064.

State machine [4.2, B]
    The generic CiA 402 machine with SINAMICS stops: shutdown = OFF1 (ramp p1121), disable
    operation = pulses off (coast), quick stop = OFF3 (ramp p1135), disable voltage = OFF2.
    A fault reacts with its own OFF1 / OFF2 / OFF3, then Fault.

PDOs [2.4, 2.5] (pdo)
    At most 25 valid RPDOs (alarm A08758 on the CU, EMCY 0x1001; only the first 25 that became
    valid are received). A synchronous RPDO received after SYNC k takes effect at SYNC k + 1;
    asynchronous ones (0xFE, the default) at once. Remapping as the manual's online procedure
    (§4.3.1: COB-ID invalid, the entries, COB-ID valid) with every option: the entries of an
    invalid PDO are written whatever sub 0 holds, sub 0 follows the leading non-zero entries,
    the 64-bit limit is checked when the PDO becomes valid. ``mapping_sub0_read_only``: the
    manual's read-only sub 0 (default false: the EDS's read-write, so a CiA 301 master's sub 0
    = 0, entries, sub 0 = n works as well).

Telegram monitoring [2.4, §2.10]
    An RPDO whose mean cycle (exponential average, weight 0.1, over at least 8 intervals, frame time
    stamps; 3 % below the limit are taken as SYNC jitter)
    is below 2 x p8848 (option ``p8848``, ms, the value at boot) raises A08751 on its drive
    object (EMCY 0x8110); it goes when the mean is 5 % above the limit or the RPDO has been
    silent for 1 s. With the factory 4 ms a SYNC-driven RPDO faster than every 8 ms fails.
    p8848 can be written only while p0009 = 3 and takes effect at the reboot.

Messages, EMCY [2.6, 2.7, 6] (emcy)
    Faults and alarms per drive object (:meth:`SimS120.inject_fault`, :meth:`~SimS120.inject_alarm`,
    :meth:`~SimS120.clear_cause`): EMCY 0x1000 (register 0x81) for a fault, 0x8110 A08751,
    0x8120 A08752, 0x8130 F08700 value 2, 0x1001 other 087xx (register 0x11); bytes 3-4 the
    number, byte 5 the drive object. Alarms outside 8700..8799: no EMCY, statusword bit 7.
    0x1003 per module; 0x1003:0 = 0 acknowledges the faults of every drive object, as does a
    controlword bit 7 edge for its own; a fault whose cause persists stays; EMCY 0x0000 once
    nothing is signalled any more. r0947 / r0949 / r2110 list a drive object's messages.

Node id [1.3] (address)
    Read at POWER ON (:meth:`SimS120.power_off` / :meth:`~SimS120.power_on`): the address switch
    (option ``address_switch``, :meth:`~SimS120.set_address_switch`) when it holds 1..127, shown
    in p8620; else the saved p8620 (factory: the node config's id). The node then answers, boots
    and sends under that id; COB-IDs still at their predefined value follow it.

Error control [2.2, 6.5]
    Heartbeat producer only (0x1016 removed if an EDS brings it). Node guarding and life
    guarding only while 0x1017 = 0 (as soon as it is non-zero the drive uses heartbeat: RTRs
    get no answer and life guarding is off). On a life guarding event every motor drive object
    raises F08700 with value 2 (EMCY 0x8130): a fault with the OFF1 / OFF2 / OFF3 of its p8641
    (1 / 2 / 3; option ``p8641``), an alarm where p8641 = 0 (the factory "no reaction"); then
    the NMT reaction p8609[0] = 0x1029:1 (0 pre-operational, 1 no change, 2 stopped). The
    alarms go when the RTRs come back, the faults can then be acknowledged. A fault outside
    the CAN range applies p8609[1] = 0x1029:2. 0x6007 is p8641 of its drive object, so it reads
    back the reaction in effect (0 by default) whatever the EDS prints (the V4.8 file: 3).

Parameters [3] (parameters)
    0x2000 + number on the drive object selected by p8630[0] (0x41B6:0; 0 = none: every window
    access aborts 0x06020000), sub-index + 256 x p8630[1] = parameter index, number + 10000 x
    p8630[2]. p8630 itself is always reachable. A parameter the selected object lacks aborts
    0x06020000, an index beyond it 0x06090011, r-parameters 0x06010002, out of range
    0x06090031 / 0x06090032 / 0x06090030 (choices). Save 0x1010:1 "save" (all parameters of
    every drive object and the stored CANopen objects), :2 communication objects, :3
    application objects (partial saves only after a full one: 0x08000020); restore 0x1011
    "load" takes effect at once (RAM; the saved values stay until the next save).

Not modelled: PP / homing (EPOS), free process-data objects 0x58xx (stored only), BICO
interconnection (every mapped object acts), the SDO/PZD split of §4.5 (one value per object),
the extra SDO servers 0x1201.. (stored only), 0x6094 (stored, not applied), p1080 (stored, no
minimum speed), p8685, p2118 / p2119 message types, the infeed, bus-off / error passive
(A08752 only by injection), the TPDO limit ratio (lost figure), the bit rate (p8622 is not in the
manual), p0009 states other than the reboot on 0.
"""

from drive_bridge.sim.s120.axis import S120Axis
from drive_bridge.sim.s120.drive import SimS120
from drive_bridge.sim.s120.emcy import Message, S120Emcy
from drive_bridge.sim.s120.options import S120_OPTIONS
from drive_bridge.sim.s120.pdo import S120PdoEngine
from drive_bridge.sim.s120.view import DriveObjectView

__all__ = ['DriveObjectView', 'Message', 'S120Axis', 'S120Emcy', 'S120PdoEngine', 'S120_OPTIONS', 'SimS120']
