"""Pure pieces of the core: CiA 402 state table, modes, EMCY and SDO codecs, PDO layouts."""
from __future__ import annotations

from pathlib import Path

import can
import canopen
import pytest
from canopen.objectdictionary import datatypes as dt

from drive_bridge.cia301.emcy import decode_emcy, describe_code, describe_register
from drive_bridge.cia402 import statemachine as sm
from drive_bridge.cia402.modes import Mode, mode_name, parse_mode
from drive_bridge.cia402.statemachine import State, next_command, state_from_statusword
from drive_bridge.families import get_family
from drive_bridge.master.errors import ObjectAddress, SdoError
from drive_bridge.master.pdo import ProcessImage, compile_pdo
from drive_bridge.master.sdo import abort_text, decode, encode
from drive_bridge.model import PdoConfig, PdoEntry

TRACES = Path(__file__).resolve().parents[2] / 'shared' / 'realdata' / 'traces'
WHERE = ObjectAddress(3, 0x2000, 1)


@pytest.mark.parametrize('statusword, state', [
    (0x0000, State.NOT_READY_TO_SWITCH_ON), (0x0250, State.SWITCH_ON_DISABLED),
    (0x0231, State.READY_TO_SWITCH_ON), (0x0233, State.SWITCHED_ON),
    (0x0237, State.OPERATION_ENABLED), (0x1637, State.OPERATION_ENABLED),
    (0x0217, State.QUICK_STOP_ACTIVE), (0x021F, State.FAULT_REACTION_ACTIVE),
    (0x0218, State.FAULT), (0x0238, State.FAULT)])
def test_statusword_is_masked_not_compared(statusword: int, state: State) -> None:
    assert state_from_statusword(statusword) is state


def test_next_command_walks_the_standard_transitions() -> None:
    path, state = [], State.SWITCH_ON_DISABLED
    drive = {sm.CMD_SHUTDOWN: State.READY_TO_SWITCH_ON, sm.CMD_SWITCH_ON: State.SWITCHED_ON,
             sm.CMD_ENABLE_OPERATION: State.OPERATION_ENABLED}
    while (command := next_command(state, State.OPERATION_ENABLED)) is not None:
        path.append(command)
        state = drive[command]
    assert path == [0x06, 0x07, 0x0F]
    assert next_command(State.OPERATION_ENABLED, State.SWITCHED_ON) == sm.CMD_DISABLE_OPERATION
    assert next_command(State.OPERATION_ENABLED, State.QUICK_STOP_ACTIVE) == sm.CMD_QUICK_STOP
    assert next_command(State.OPERATION_ENABLED, State.SWITCH_ON_DISABLED) == sm.CMD_DISABLE_VOLTAGE
    assert next_command(State.FAULT, State.OPERATION_ENABLED) is None  # needs the reset edge
    for state in State:
        if state is not State.UNKNOWN:
            assert state_from_statusword(sm.statusword_bits_for(state)) is state


def test_modes_parse_names_numbers_and_refuse_junk() -> None:
    assert parse_mode('csp') == Mode.CYCLIC_SYNC_POSITION
    assert parse_mode('Profile Position') == 1
    assert parse_mode('0x9') == 9 and parse_mode(-2) == -2
    assert mode_name(-2) == 'manufacturer(-2)' and mode_name(10) == 'cst'
    with pytest.raises(ValueError, match="unknown mode 'fast'; use a number or one of"):
        parse_mode('fast')
    with pytest.raises(ValueError, match='outside INTEGER8'):
        parse_mode(300)


def test_emcy_decoding_uses_tables_then_classes() -> None:
    event = decode_emcy(3, 'left', bytes.fromhex('1023030102030405'), 1.5)
    assert (event.code, event.register, event.manufacturer) == (0x2310, 0x03, bytes([1, 2, 3, 4, 5]))
    assert event.text == 'continuous over-current'
    assert event.register_text == 'generic, current'
    assert 'EMCY node 3 (left): 0x2310 continuous over-current' in str(event)
    assert describe_code(0x8611) == 'following error'
    assert describe_code(0x7309) == 'sensor (code 0x7309)'
    assert describe_code(0xFF42, {0xFF42: 'family text'}) == 'family text'
    assert describe_code(0xE123) == 'unknown error code 0xE123'
    assert describe_register(0x81) == 'generic, manufacturer specific'


def test_emcy_frames_of_real_traces_decode() -> None:
    decoded = []
    for name in ('pcan3.trc', 'ixxat1.converted.log'):
        for msg in can.LogReader(str(TRACES / name)):
            if 0x81 <= msg.arbitration_id <= 0xFF and not msg.is_remote_frame:
                decoded.append(decode_emcy(msg.arbitration_id - 0x80, '', bytes(msg.data), msg.timestamp))
    texts = {(e.node_id, e.code): e.text for e in decoded}
    # pcan3: the one EMCY of the machine, a heartbeat/life-guard error of node 15
    assert texts[(15, 0x8130)] == 'life guard error or heartbeat error'
    # ixxat1: DLC-0 EMCY frames are kept (as 'no error') instead of being dropped
    assert (3, 0x0000) in texts and (9, 0x0000) in texts
    assert texts[(3, 0x8120)] == 'CAN in error passive mode'
    assert len(decoded) == 8


def test_sdo_codec_round_trips_and_refuses_what_does_not_fit() -> None:
    cases = [(dt.BOOLEAN, True), (dt.INTEGER8, -128), (dt.UNSIGNED16, 65535), (dt.INTEGER32, -5),
             (dt.UNSIGNED32, 0xDEADBEEF), (dt.INTEGER64, -(2 ** 63)), (dt.UNSIGNED64, 2 ** 64 - 1),
             (dt.REAL32, 0.5), (dt.REAL64, -1e-300), (dt.VISIBLE_STRING, 'AKD'),
             (dt.OCTET_STRING, b'\x00\xff'), (dt.DOMAIN, bytes(300)), (dt.UNSIGNED24, 0xABCDEF)]
    for data_type, value in cases:
        assert decode(data_type, encode(data_type, value, WHERE), WHERE) == value
    with pytest.raises(SdoError, match=r'node 3 object 0x2000:01: cannot encode as INTEGER16: 40000 is outside'):
        encode(dt.INTEGER16, 40000, WHERE)
    with pytest.raises(SdoError, match='is not an integer'):
        encode(dt.UNSIGNED8, 1.5, WHERE)
    with pytest.raises(SdoError, match='1 byte\\(s\\) received, UNSIGNED32 needs 4'):
        decode(dt.UNSIGNED32, b'\x01', WHERE)
    assert abort_text(0x06020000) == 'object does not exist'
    assert abort_text(0x12345678) == 'unknown abort code'


def test_pdo_layout_packs_and_unpacks_signed_fields() -> None:
    eds = Path(get_family('generic_402').eds_for(1))
    od = canopen.import_od(str(eds), 5)
    rpdo = PdoConfig(1, 0x205, mapping=(PdoEntry(0x6040, 0, 16), PdoEntry(0x6060, 0, 8), PdoEntry(0x6071, 0, 16)))
    tpdo = PdoConfig(2, 0x285, mapping=(PdoEntry(0x6064, 0, 32), PdoEntry(0x606C, 0, 32)))
    layout = compile_pdo(tpdo, od)
    assert layout.length == 8
    data = (-123456).to_bytes(4, 'little', signed=True) + (-7).to_bytes(4, 'little', signed=True)
    assert dict(layout.unpack(data)) == {(0x6064, 0): -123456, (0x606C, 0): -7}
    image = ProcessImage(od, [rpdo], [tpdo])
    image.set(0x6040, 0, 0x000F)
    image.set(0x6060, 0, -2)
    image.set(0x6071, 0, -300)
    assert image.frames() == [(0x205, bytes.fromhex('0f00fe d4fe'.replace(' ', '')))]
    assert image.output(0x6071) == -300
    seen = []
    image.add_input_listener(lambda keys, stamp: seen.append((keys, stamp)))
    image.on_tpdo(0x285, data, 2.5)
    assert image.get(0x6064) == -123456 and image.input_stamps[(0x6064, 0)] == 2.5
    assert seen == [(frozenset({(0x6064, 0), (0x606C, 0)}), 2.5)]
    image.on_tpdo(0x285, data[:5], 3.0)  # too short: counted and reported, not decoded
    assert image.rx_errors == 1 and 'TPDO 0x285: 5 byte(s) received, mapping needs 8' in image.last_rx_error
    assert image.input_stamps[(0x6064, 0)] == 2.5
