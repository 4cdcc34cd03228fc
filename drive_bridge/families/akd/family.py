"""Kollmorgen AKD servo drives over CANopen (manual rev. F, 903-200004-03; shared/drives/akd.md).

What the bridge needs to know beyond the EDS (drive_bridge/families/akd/data/akd.eds, written by
families/akd/edsgen.py):

- one axis per node; PVT is interpolation sub-mode -2 of interpolated position mode and is
  the default way to stream trajectories (``interpolation: pvt``);
- the PVT buffer warnings n704 (overflow, EMCY 0x8584) and n705 (underflow, 0x8585);
- the EMCY / fault table of the manual (§6.1), code -> "Fnnn/nnnn text";
- a default PDO map that fits the AKD's PDO rules (whole bytes, at most 8 bytes per PDO,
  four PDOs each way, RPDO transmission types 1..240 or 255) and carries everything the
  bridge uses in pp, pv, tq, hm, ip (linear and PVT) and csp without SDO in the cycle:

  ======  =================================================  =====
  PDO     objects                                            bytes
  ======  =================================================  =====
  RPDO1   0x6040 controlword, 0x6060 modes of operation,      5
          0x6071 target torque
  RPDO2   0x60C1:1 PVT/IP position, 0x60C1:2 PVT time (ms)    8
  RPDO3   0x60C1:3 PVT velocity (counts/s)                    4
  RPDO4   0x607A target position, 0x60FF target velocity      8
  TPDO1   0x6041 statusword, 0x6061 modes display,            7
          0x60C4:2 free PVT buffer places
  TPDO2   0x6064 position actual, 0x606C velocity actual      8
  TPDO3   0x6077 torque actual                                2
  ======  =================================================  =====

  RPDO2/RPDO3 are the manual's own PVT mapping (§7.2.2.2); the bridge sends them only when
  it writes a point (master/pdo.py), and the drive takes a point once all of 0x60C1:1..3
  arrived. TPDO4 is not used (the bridge disables it at boot).

Known gap: the manual says 0x606C is sent in rpm over PDO (and in user units x1000 over
SDO); the bridge has one velocity factor per axis, so with a real AKD the reported joint
velocity needs that factor chosen for the PDO unit (the simulator reports counts/s unless
its option ``velocity_pdo_rpm`` is set).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

from drive_bridge.cia301.cob import predefined_cob_id
from drive_bridge.cia301.emcy import EmcyEvent, Severity
from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.profile import PvtRecord
from drive_bridge.families.akd.parameter_table import AKD_PARAMETERS
from drive_bridge.families.akd.parameters import ASCII_CHANNEL, COMMAND_SUB, STORE_COMMANDS, AkdParameters
from drive_bridge.families.interface import DriveFamily
from drive_bridge.families.node import FamilyNode
from drive_bridge.families.parameters import ParameterPort
from drive_bridge.families.registry import register_family
from drive_bridge.families.traits import ModeTraits
from drive_bridge.model import AxisConfig, NodeConfig, PdoConfig, PdoEntry
from drive_bridge.resources import family_data

SYNC_EVERY_CYCLE = 1
EVENT_DRIVEN = 255  # the AKD knows no type 254
EMCY_PVT_OVERFLOW = 0x8584  # n704
EMCY_PVT_UNDERFLOW = 0x8585  # n705
PVT_SUBMODE = -2

# The AKD's EMCY error codes (manual §6.1, all 171 rows in the manual's order; akd.md §3):
# code -> "<AKD fault (Fnnn) or warning (nnnn) code> <description as printed>".
AKD_EMCY_TEXTS: Mapping[int, str] = {
    0x0000: 'Emergency error free',
    0x1080: 'General warning',
    0x1081: 'General error',
    0x3110: 'F523 Bus over voltage',
    0x3120: 'F247 Bus under voltage',
    0x3130: 'F503 Phase failure',
    0x3180: 'n503 Warning: Supply missing phase',
    0x3210: 'F501 DC link over-voltage',
    0x3220: 'F502 DC link under-voltage',
    0x3280: 'n502 Warning: Bus under voltage.',
    0x3281: 'n521 Warning: Dynamic Braking I2T.',
    0x3282: 'F519 Regen short circuit.',
    0x4210: 'F234 Excess temperature, device (control board)',
    0x4310: 'F235 Excess temperature, drive (heat sink)',
    0x4380: 'F236 Power temperature sensor 2 high',
    0x4381: 'F237 Power temperature sensor 3 high.',
    0x4382: 'F535 (no description in the manual)',
    0x4390: 'n234 Warning: Control temperature sensor 1 high.',
    0x4391: 'n235 Warning: Power temperature sensor 1 high.',
    0x4392: 'n236 Warning: Power temperature sensor 2 high.',
    0x4393: 'n237 Warning: Power temperature sensor 3 high.',
    0x4394: 'n240 Warning: Control temperature sensor 1 low.',
    0x4395: 'n241 Warning: Power temperature sensor 1 low.',
    0x4396: 'n242 Warning: Power temperature sensor 2 low.',
    0x4397: 'n243 Warning: Control temperature sensor 1 low.',
    0x4398: 'F240 Control temperature sensor 1 low.',
    0x4399: 'F241 Power temperature sensor 1 low.',
    0x439A: 'F242 Power temperature sensor 2 low.',
    0x439B: 'F243 Power temperature sensor 3 low.',
    0x5113: 'F512 5V0 under voltage',
    0x5114: 'F505 1V2 under voltage',
    0x5115: 'F507 2V5 under voltage',
    0x5116: 'F509 3V3 under voltage',
    0x5117: 'F514 +12V0 under voltage',
    0x5118: 'F516 -12V0 under voltage',
    0x5119: 'F518 Analog 3V3 under voltage',
    0x5180: 'F504 1V2 over voltage',
    0x5181: 'F506 2V5 over voltage',
    0x5182: 'F508 3V3 over voltage',
    0x5183: 'F510 5V0 over voltage',
    0x5184: 'F513 +12V0 over voltage',
    0x5185: 'F515 -12V0 over voltage',
    0x5186: 'F517 Analog 3V3 over voltage',
    0x5510: 'F201 Internal RAM failed.',
    0x5530: 'F105 Hardware memory, non-volatile memory stamp invalid.',
    0x5580: 'F106 Hardware memory, non-volatile memory data',
    0x5581: 'F202 Hardware memory, external Ram for resident firmware failed',
    0x5582: 'F203 Hardware memory, code integrity failed for resident firmware',
    0x5583: 'F102 Hardware memory, resident firmware failed',
    0x5584: 'F103 Hardware memory, resident FPGA failed',
    0x5585: 'F104 Hardware memory, operational FPGA failed',
    0x6380: 'F532 Drive motor parameters setup incomplete.',
    0x7180: 'F301 Motor overheat',
    0x7182: 'F305 Motor open circuit',
    0x7183: 'F306 Motor short circuit',
    0x7184: 'F307 Motor brake applied',
    0x7185: 'F436 (no description in the manual)',
    0x7186: 'n301 Warning: Motor overheated.',
    0x7187: 'F308 Voltage exceeds motor rating.',
    0x7303: 'F426 Resolver 1 fault',
    0x7305: 'F417 Incremental sensor 1 fault',
    0x7380: 'F402 Feedback 1 analogue fault',
    0x7381: 'F403 Feedback 1 EnDat communication fault',
    0x7382: 'F404 Feedback 1 illegal hall',
    0x7383: 'F405 Feedback 1 BiSS watchdog',
    0x7384: 'F406 Feedback 1 BiSS multi cycle',
    0x7385: 'F407 Feedback 1 BiSS sensor',
    0x7386: 'F408 Feedback 1 SFD configuration',
    0x7387: 'F409 Feedback 1 SFD UART overrun',
    0x7388: 'F410 Feedback 1 SFD UART frame',
    0x7389: 'F412 Feedback 1 SFD UART parity',
    0x738A: 'F413 Feedback 1 SFD transfer timeout',
    0x738B: 'F415 Feedback 1 SFD mult. corrupt position',
    0x738C: 'F416 Feedback 1 SFD Transfer incomplete',
    0x738D: 'F418 Feedback 1 power supply fault',
    0x738E: 'F401 Feedback 1 failed to set feedback',
    0x7390: 'n414 Warning: SFD single corrupted position.',
    0x7391: 'F419 Encoder init procedure failed',
    0x7392: 'F534 Failed to read motor parameters from feedback device.',
    0x73A0: 'F424 Feedback 2 resolver amplitude low',
    0x73A1: 'F425 Feedback 2 resolver amplitude high',
    0x73A2: 'F425 Feedback 2 resolver fault',
    0x73A3: 'F427 Feedback 2 analogue low',
    0x73A4: 'F428 Feedback 2 analogue high',
    0x73A5: 'F429 Feedback 2 incremental low',
    0x73A6: 'F430 Feedback 2 incremental high',
    0x73A7: 'F431 Feedback 2 halls',
    0x73A8: 'F432 Feedback 2 communication',
    0x73A9: 'Reserved',
    0x73AA: 'Reserved',
    0x73C0: 'F473 Wake and Shake. Insufficient movement',
    0x73C1: 'F475 Wake and Shake. Excess movement.',
    0x73C2: 'F476 Wake and Shake. Fine-coarse delta too large.',
    0x73C3: 'F478 Wake and Shake. Overspeed.',
    0x73C4: 'F479 Wake and Shake. Loop angle delta too large.',
    0x73C5: 'F482 Commutation not initialized',
    0x73C6: 'F483 Motor U phase missing.',
    0x73C7: 'F484 Motor V phase missing.',
    0x73C8: 'F485 Motor W phase missing.',
    0x73C9: 'n478 Warning: Wake and Shake. Overspeed.',
    0x73CA: 'n479 Warning: Wake and Shake. Loop angle delta too large.',
    0x8130: 'F129 Life Guard Error or Heartbeat Error',
    0x8180: 'n702 Warning: Fieldbus communication lost.',
    0x8280: 'F601 (no description in the manual)',
    0x8311: 'F304 Excess torque',
    0x8331: 'F524 Torque fault',
    0x8380: 'n524 Warning: Drive foldback',
    0x8381: 'n304 Warning: Motor foldback',
    0x8382: 'n309 Warning: (no description in the manual)',
    0x8480: 'F302 Velocity overspeed',
    0x8482: 'F480 Fieldbus command velocity too high',
    0x8481: 'F703 Emergency timeout occurred while axis should disable',
    0x8483: 'F481 Fieldbus command velocity too low.',
    0x8580: 'F107 Software limit switch, positive',
    0x8581: 'F108 Software limit switch, negative',
    0x8582: 'n107 Warning: Positive software position limit is exceeded.',
    0x8583: 'n108 Warning: Negative software position limit is exceeded.',
    0x8584: 'n704 Warning: PVT buffer overflow',
    0x8585: 'n705 Warning: PVT buffer underflow',
    0x8586: 'n127 Warning: Scale factor of PVT velocity command over range.',
    0x8611: 'F439 Following error',
    0x8684: 'n123 Warning: Motion global warning',
    0x8685: 'F138 Instability during autotune',
    0x8686: 'F151 Not enough distance to move; Motion Exception',
    0x8687: 'F152 Not enough distance to move; Following Motion Exception',
    0x8688: 'F153 Velocity Limit Violation, Exceeding Max Limit',
    0x8689: 'F154 Following Motion Failed; Check Motion Parameters',
    0x868A: 'F156 Target Position crossed due to Stop command',
    0x86A0: 'F157 Homing Index pulse not found',
    0x86A1: 'F158 Homing Reference Switch not found',
    0x86A2: 'F159 Failed to set motion task parameters',
    0x86A3: 'F160 Motion Task Activation Failed',
    0x86A4: 'F161 Homing Procedure Failed',
    0x86A5: 'F139 Target Position Over Short due to invalid Motion task activation.',
    0x86A6: 'n163 Warning: MT.NUM exceeds limit.',
    0x86A7: 'n164 Warning: Motion task is not initialized.',
    0x86A8: 'n165 Warning: Motion task target position is out.',
    0x86A9: 'n167 Warning: (no description in the manual)',
    0x86AA: 'n168 Warning: Invalid bit combination in the motion task control word.',
    0x86AB: 'n169 Warning: 1:1 profile cannot be triggered on the fly.',
    0x86AC: 'n170 Warning: Customer profile table is not initialized.',
    0x86AD: 'n171 Warning: (no description in the manual)',
    0x86AE: 'n172 Warning: (no description in the manual)',
    0x86B0: 'F438 Following error (numeric)',
    0x8780: 'F125 Fieldbus synchronization lost',
    0x8781: 'n125 Warning: Fieldbus PLL unlocked.',
    0x8AF0: 'F137 Homing and Feedback mismatch',
    0x8AF1: 'n140 Warning: (no description in the manual)',
    0xFF00: 'F701 Fieldbus runtime fault',
    0xFF01: 'F702 Fieldbus communication lost',
    0xFF02: 'F529 Iu offset limit exceeded',
    0xFF03: 'F530 Iv offset limit exceeded',
    0xFF04: 'F521 Stored energy reached critical point',
    0xFF05: 'F527 Iu detection stuck',
    0xFF06: 'F528 Iv detection stuck',
    0xFF07: 'F525 Control output over current',
    0xFF08: 'F526 Current sensor short circuit',
    0xFF09: 'F128 Axis dpoles',
    0xFF0A: 'F531 Power stage fault',
    0xFF0B: 'F602 Safe torque off',
    0xFF0C: 'F131 Emulated encoder line break.',
    0xFF0D: 'F130 Secondary feedback supply over current.',
    0xFF0E: 'F134 Secondary feedback illegal state.',
    0xFF0F: 'F245 External fault.',
    0xFF10: 'n414 Warning: SFD single corrupted position.',
    0xFF11: 'F101 Not compatible Firmware',
    0xFF12: 'n439 Warning: Following error (user)',
    0xFF13: 'n438 Warning: Following error (numeric)',
    0xFF14: 'n102 Warning: Operational FPGA is not a default FPGA.',
    0xFF15: 'n101 Warning: The FPGA is a laboratory FPGA',
    0xFF16: 'n602 Warning: Safe torque off.',
}


def _entry(index: int, bits: int, subindex: int = 0) -> PdoEntry:
    return PdoEntry(index, subindex, bits)


class AkdNode(FamilyNode):
    """One AKD at run time: the CiA 402 axis, and its ASCII parameters."""

    def parameters(self, port: ParameterPort) -> AkdParameters:
        """ASCII parameters (DRV.ACC, FBUS.PARAM04, ...) over the ASCII channel 0x2026."""
        return AkdParameters(port)


@register_family
class Akd(DriveFamily):
    """Kollmorgen AKD (CANopen built in), one axis per node."""

    name = 'akd'
    description = 'Kollmorgen AKD servo drive (CANopen; PVT interpolation)'
    vendor_safety_objects = {
        0x36E5: 'FBUS.PARAM01, the CAN bit rate',
        0x36E8: 'FBUS.PARAM04, SYNC supervision (F125 after 3 missing SYNCs)',
    }
    default_eds = family_data('akd', 'akd.eds')
    emcy_texts = AKD_EMCY_TEXTS
    # 0x6502 = 0x65 (pp, pv, hm, ip) but 0x6060 accepts 4 and 8 too (akd.md §10.9); no csv/cst
    modes = ModeTraits(
        accepted=frozenset({Mode.PROFILE_POSITION, Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE, Mode.HOMING,
                            Mode.INTERPOLATED_POSITION, Mode.CYCLIC_SYNC_POSITION}),
        defaults={'mode': 'ip', 'position_mode': 'ip', 'velocity_mode': 'pv', 'effort_mode': 'pt'},
        pvt_submode=PVT_SUBMODE, default_interpolation='pvt',
        interpolation_fault_codes=frozenset({EMCY_PVT_OVERFLOW, EMCY_PVT_UNDERFLOW}))

    def decode_emcy(self, node_id: int, node_name: str, data: bytes, timestamp: float) -> EmcyEvent:
        """The manual's table; its nNNN rows and the general warning are warnings (the drive
        keeps running), its FNNN rows faults."""
        event = super().decode_emcy(node_id, node_name, data, timestamp)
        text = AKD_EMCY_TEXTS.get(event.code, '')
        if event.code == 0x1080 or (text[:1] == 'n' and text[1:4].isdigit()):
            return event.with_meaning(severity=Severity.WARNING)
        return event

    def pvt_record(self, slot: int) -> PvtRecord | None:
        """The AKD's PVT point: 0x60C1:1 position (counts), :2 time (ms), :3 velocity
        (counts/s); the drive takes it once all three arrived (akd.md §7.2.2.2)."""
        record = obj.for_axis(obj.INTERPOLATION_DATA_RECORD, slot)
        return PvtRecord(position=(record, 1), time=(record, 2), velocity=(record, 3), time_unit=0.001)

    def node(self, config: NodeConfig) -> AkdNode:
        return AkdNode(self, config)

    def stores_parameters(self, config: NodeConfig, index: int, subindex: int) -> bool:
        """Also DRV.NVSAVE's own object, and the ASCII command channel, which passes any command
        (DRV.NVSAVE, DRV.NVLOAD among them): clients reach it through ~/param_write instead."""
        store_objects = {spec.index for name, spec in AKD_PARAMETERS.items() if name in STORE_COMMANDS and spec.index}
        return (super().stores_parameters(config, index, subindex) or index in store_objects
                or (index, subindex) == (ASCII_CHANNEL, COMMAND_SUB))

    def default_pdos(self, node_id: int, axes: Sequence[AxisConfig],
                     synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        if len(axes) > self.axes.max_count:
            raise ValueError(f'an AKD drives one axis, {len(axes)} given')
        rx_type = SYNC_EVERY_CYCLE if synchronous else EVENT_DRIVEN
        tx_type = SYNC_EVERY_CYCLE if synchronous else EVENT_DRIVEN
        timer = 0 if synchronous else 10  # ms: event-driven TPDOs also refresh periodically
        record = obj.INTERPOLATION_DATA_RECORD
        rx_maps = {
            1: (_entry(obj.CONTROLWORD, 16), _entry(obj.MODES_OF_OPERATION, 8), _entry(obj.TARGET_TORQUE, 16)),
            2: (_entry(record, 32, 1), _entry(record, 32, 2)),
            3: (_entry(record, 32, 3),),
            4: (_entry(obj.TARGET_POSITION, 32), _entry(obj.TARGET_VELOCITY, 32)),
        }
        tx_maps = {
            1: (_entry(obj.STATUSWORD, 16), _entry(obj.MODES_OF_OPERATION_DISPLAY, 8),
                _entry(obj.INTERPOLATION_DATA_CONFIGURATION, 32, 2)),
            2: (_entry(obj.POSITION_ACTUAL, 32), _entry(obj.VELOCITY_ACTUAL, 32)),
            3: (_entry(obj.TORQUE_ACTUAL, 16),),
        }
        rpdos = tuple(PdoConfig(n, predefined_cob_id('rpdo', n, node_id), transmission=rx_type, mapping=m)
                      for n, m in rx_maps.items())
        tpdos = tuple(PdoConfig(n, predefined_cob_id('tpdo', n, node_id), transmission=tx_type,
                                event_timer=timer, mapping=m)
                      for n, m in tx_maps.items())
        return rpdos, tpdos
