"""The interface packages: generated types import, each one crosses rclpy intact, and
control_msgs' types are upstream's for Jazzy (type hashes)."""
from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType

import control_msgs
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointComponentTolerance, JointTolerance
from drive_bridge_interfaces.msg import AxisState, CanFrame, Emcy, SdoValue
from drive_bridge_interfaces.srv import NmtCommand, SdoRead, SdoWrite
from rclpy.action import ActionServer

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


# RIHS01 type hashes of control_msgs on ROS 2 Jazzy, computed once from upstream's own files:
# ros-controls/control_msgs, branch jazzy at commit f901df2662f22a39a06aa04a85a34602c47e3cc0
# (release 5.8.0; the three files last changed in 11fdcdf, 2021), control_msgs/action/
# FollowJointTrajectory.action, msg/JointTolerance.msg and msg/JointComponentTolerance.msg
# built as they are with rosidl (rosidl_generator_type_description of this venv's Jazzy
# wheels) in a scratch package. The same hashes come from any Jazzy install of control_msgs.
UPSTREAM_COMMIT = 'f901df2662f22a39a06aa04a85a34602c47e3cc0'
UPSTREAM_HASHES = {
    'control_msgs/action/FollowJointTrajectory':
        'RIHS01_738ebcb7a2d7cfa42f9f1001cc99ce3a4383d1cfe508015d9be8485e4b1c66f6',
    'control_msgs/action/FollowJointTrajectory_Goal':
        'RIHS01_8a9060704b269608f5a340934cc26e66869dd14bdac29e2e7fd9ec8b9882d205',
    'control_msgs/action/FollowJointTrajectory_Result':
        'RIHS01_8002e99ed2c14c6faa522f2a93c26d744c5982f254f9e98ff9c6f19789bdb220',
    'control_msgs/action/FollowJointTrajectory_Feedback':
        'RIHS01_3fd0aaecf71725121ae1ff7f01098a5e0da581e672be18a6b2c286cb43d96b49',
    'control_msgs/action/FollowJointTrajectory_FeedbackMessage':
        'RIHS01_80398fcb9674a79081a9906e2ccf0c804dd7cb15e22e362e606ee87186beab71',
    'control_msgs/action/FollowJointTrajectory_SendGoal':
        'RIHS01_b13789dddc325a7a962825c45e28c77d37237ec129dd0c34dc5994562938c57f',
    'control_msgs/action/FollowJointTrajectory_SendGoal_Request':
        'RIHS01_179c93691f1f6d1d115881ff88c3917b7cc6eac2ba4bf56766cc7c4389e19ef1',
    'control_msgs/action/FollowJointTrajectory_SendGoal_Response':
        'RIHS01_e6a48ba740ae254500129a877f0b071be8663a115da1a539b74599cc97921fbf',
    'control_msgs/action/FollowJointTrajectory_SendGoal_Event':
        'RIHS01_906dd566308db02673c73c654f69bdd84738589629c1bc2841ddb49059ed1c6f',
    'control_msgs/action/FollowJointTrajectory_GetResult':
        'RIHS01_e3ceb38e3e1867c8dc0f46014df26e90eb93422f27e9e97f936e07f94be4bc8b',
    'control_msgs/action/FollowJointTrajectory_GetResult_Request':
        'RIHS01_ecf7ea8463d3beec7084bca75216d0b01b87b6e1e4e09679bb26093041efcbe9',
    'control_msgs/action/FollowJointTrajectory_GetResult_Response':
        'RIHS01_08eefbaa146ce02ba45898d5e99160afd6c4c54a30d159aee0f2ca6035b1580f',
    'control_msgs/action/FollowJointTrajectory_GetResult_Event':
        'RIHS01_43161a489e52daaa5bbc2fa74f73f1804d099574fcf8f819170807d75472662a',
    'control_msgs/msg/JointTolerance': 'RIHS01_c254f9cece0f3b733017b6990fd46d1326e25242d6b8844398c97d9a88e7d648',
    'control_msgs/msg/JointComponentTolerance':
        'RIHS01_739ea7566931944d33830fa10f1bf5e7a7fbdc3172bce7a7eaac642bd6e3ffa4',
}


def share_of(module: ModuleType) -> Path:
    """share/<package> of the install prefix an interface package was imported from
    (<prefix>/lib/pythonX.Y/site-packages/<package>: this venv, /opt/ros/jazzy, a workspace)."""
    return Path(module.__file__ or '').resolve().parents[4] / 'share' / module.__name__


def installed_hashes(kind: str, name: str) -> dict[str, str]:
    """The type hashes rosidl wrote for an installed interface (share/<pkg>/<kind>/<name>.json)."""
    share = share_of(control_msgs)
    data = json.loads((share / kind / f'{name}.json').read_text())
    return {h['type_name']: h['hash_string'] for h in data['type_hashes']}


def test_control_msgs_types_hash_as_upstreams_jazzy(ros: RosHarness) -> None:
    built = {**installed_hashes('action', 'FollowJointTrajectory'), **installed_hashes('msg', 'JointTolerance'),
             **installed_hashes('msg', 'JointComponentTolerance')}
    assert {k: v for k, v in built.items() if k.startswith('control_msgs/')} == UPSTREAM_HASHES
    # the hashes the middleware announces for the types rclpy uses: a topic of each message, and
    # the feedback topic of an action server (what a MoveIt client matches against)
    node = ros.node('type_hashes')
    for msg_type, topic in ((JointTolerance, 'tolerance'), (JointComponentTolerance, 'component_tolerance')):
        node.create_publisher(msg_type, topic, 1)
    ActionServer(node, FollowJointTrajectory, 'follow_joint_trajectory', lambda goal: None)
    announced = {
        'control_msgs/msg/JointTolerance': 'tolerance',
        'control_msgs/msg/JointComponentTolerance': 'component_tolerance',
        'control_msgs/action/FollowJointTrajectory_FeedbackMessage': 'follow_joint_trajectory/_action/feedback',
    }
    for type_name, topic in announced.items():
        infos = wait_for(lambda t=topic: node.get_publishers_info_by_topic(t), 5, f'publisher of {topic}')
        assert (infos[0].topic_type, str(infos[0].topic_type_hash)) == (type_name, UPSTREAM_HASHES[type_name])


def test_the_bridge_defines_no_trajectory_action_of_its_own() -> None:
    """MoveIt speaks control_msgs' type only: a look-alike of ours would never connect."""
    import drive_bridge_interfaces
    share = share_of(drive_bridge_interfaces)
    assert not list(share.glob('action/*.action')), 'drive_bridge_interfaces ships an action again'
    assert not hasattr(drive_bridge_interfaces.msg, 'JointTolerance')
