"""The interface package: generated types import, and each one crosses rclpy intact."""
from __future__ import annotations

from drive_bridge_interfaces.msg import AxisState, CanFrame, Emcy, SdoValue
from drive_bridge_interfaces.srv import NmtCommand, SdoRead, SdoWrite

from rostools import RosHarness, wait_for

# CiA 301 basic data type codes, from the standard (not from the generated code).
CIA301_TYPES = {
    'BOOLEAN': 0x01, 'INTEGER8': 0x02, 'INTEGER16': 0x03, 'INTEGER32': 0x04,
    'UNSIGNED8': 0x05, 'UNSIGNED16': 0x06, 'UNSIGNED32': 0x07, 'REAL32': 0x08,
    'VISIBLE_STRING': 0x09, 'OCTET_STRING': 0x0A, 'UNICODE_STRING': 0x0B, 'DOMAIN': 0x0F,
    'REAL64': 0x11, 'INTEGER64': 0x15, 'UNSIGNED64': 0x1B,
}


def test_sdo_value_has_every_cia301_basic_type() -> None:
    for name, code in CIA301_TYPES.items():
        assert getattr(SdoValue, name) == code, name


def test_nmt_command_specifiers_are_cia301() -> None:
    assert (NmtCommand.Request.START, NmtCommand.Request.STOP) == (1, 2)
    assert NmtCommand.Request.ENTER_PRE_OPERATIONAL == 128
    assert NmtCommand.Request.RESET_NODE == 129
    assert NmtCommand.Request.RESET_COMMUNICATION == 130


def test_sdo_read_write_round_trip_through_rclpy(ros: RosHarness) -> None:
    store: dict[tuple[int, int, int], SdoValue] = {}

    def write(request: SdoWrite.Request, response: SdoWrite.Response) -> SdoWrite.Response:
        key = (request.node_id, request.index, request.subindex)
        if request.index == 0x1000:
            response.success, response.abort_code = False, 0x06010002
            response.message = 'attempt to write a read only object'
        else:
            store[key] = request.value
            response.success = True
        return response

    def read(request: SdoRead.Request, response: SdoRead.Response) -> SdoRead.Response:
        value = store.get((request.node_id, request.index, request.subindex))
        response.success = value is not None
        if value is not None:
            response.value = value
        return response

    server = ros.node('sdo_server')
    server.create_service(SdoWrite, 'sdo_write', write)
    server.create_service(SdoRead, 'sdo_read', read)
    client = ros.node('sdo_client')
    write_client = client.create_client(SdoWrite, 'sdo_write')
    read_client = client.create_client(SdoRead, 'sdo_read')

    values = [
        SdoValue(data_type=SdoValue.INTEGER64, int_value=-(2**63)),
        SdoValue(data_type=SdoValue.UNSIGNED64, uint_value=2**64 - 1),
        SdoValue(data_type=SdoValue.REAL32, float_value=-1.5),
        SdoValue(data_type=SdoValue.VISIBLE_STRING, string_value='AKD-P00606'),
        SdoValue(data_type=SdoValue.DOMAIN, bytes_value=bytes(range(256))),
        SdoValue(data_type=SdoValue.BOOLEAN, bool_value=True),
    ]
    for sub, value in enumerate(values, start=1):
        request = SdoWrite.Request(node_id=5, index=0x2000, subindex=sub, value=value)
        assert ros.call(write_client, request).success
    for sub, value in enumerate(values, start=1):
        response = ros.call(read_client, SdoRead.Request(node_id=5, index=0x2000, subindex=sub))
        assert response.success
        assert response.value == value

    refused = ros.call(write_client, SdoWrite.Request(node_id=5, index=0x1000, subindex=0))
    assert (refused.success, refused.abort_code) == (False, 0x06010002)
    assert 'read only' in refused.message


def test_nmt_command_round_trip_through_rclpy(ros: RosHarness) -> None:
    seen: list[tuple[int, int]] = []

    def handle(request: NmtCommand.Request, response: NmtCommand.Response) -> NmtCommand.Response:
        seen.append((request.command, request.node_id))
        response.success = request.command in (1, 2, 128, 129, 130)
        response.message = '' if response.success else f'unknown NMT command {request.command}'
        return response

    ros.node('nmt_server').create_service(NmtCommand, 'nmt', handle)
    client = ros.node('nmt_client').create_client(NmtCommand, 'nmt')
    ok = ros.call(client, NmtCommand.Request(command=NmtCommand.Request.RESET_NODE, node_id=0))
    bad = ros.call(client, NmtCommand.Request(command=7, node_id=3))
    assert ok.success and not bad.success and 'unknown NMT command 7' in bad.message
    assert seen == [(129, 0), (7, 3)]


def test_can_frame_emcy_and_axis_state_published_and_received(ros: RosHarness) -> None:
    pub_node = ros.node('publisher')
    sub_node = ros.node('subscriber')
    received: dict[str, object] = {}
    for topic, msg_type in (('frames', CanFrame), ('emcy', Emcy), ('axis', AxisState)):
        sub_node.create_subscription(msg_type, topic, lambda m, t=topic: received.__setitem__(t, m), 10)
    frame = CanFrame(id=0x183, dlc=6, data=bytes([0x37, 0x02, 0, 0, 1, 0]),
                     direction=CanFrame.DIRECTION_RX)
    frame.header.frame_id = 'can0'
    emcy = Emcy(node_id=3, error_code=0x2310, error_register=0x03,
                manufacturer_data=[1, 2, 3, 4, 5], text='continuous over-current')
    axis = AxisState(joint_name='elbow', state=AxisState.STATE_OPERATION_ENABLED,
                     statusword=0x0237, mode=8, mode_name='CSP')
    publishers = {t: pub_node.create_publisher(type(m), t, 10)
                  for t, m in (('frames', frame), ('emcy', emcy), ('axis', axis))}
    expected = {'frames': frame, 'emcy': emcy, 'axis': axis}

    def all_received() -> bool:
        for topic, msg in expected.items():
            if topic not in received:
                publishers[topic].publish(msg)
        return len(received) == len(expected)

    wait_for(all_received, 10, 'all three messages')
    assert received == expected
