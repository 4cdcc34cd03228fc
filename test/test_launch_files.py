"""The files a ROS stack starts the bridge with: launch files, the parameter file, the
topic-based ros2_control example.

launch and launch_ros are not on PyPI, so here each launch file is read with ``ast``: every
executable, installed file, launch argument and parameter it names must exist (where launch_ros
is importable, the launch description is also built). The parameter file is loaded by rcl into
a running node; the ros2_control example's URDF and controllers name the bridge's own topics,
joints and interfaces, and its topics drive the demo as topic_based_ros2_control would.
"""
from __future__ import annotations

import ast
import contextlib
import dataclasses
import importlib.metadata
import re
import runpy
import time
import xml.etree.ElementTree as ET
from dataclasses import fields
from pathlib import Path
from unittest import mock

import pytest
import setuptools
import yaml
from drive_bridge_interfaces.srv import AxisCommand
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from bustools import demo_data
from drive_bridge.cli.bridge import params_files_set_config
from drive_bridge.model import RecordConfig
from drive_bridge.ros import recording
from drive_bridge.ros.node import BusNode
from drive_bridge.ros.parameters import BridgeParameters
from rostools import RosHarness, wait_for

REPO = Path(__file__).resolve().parents[1]
LAUNCH_FILES = sorted((REPO / 'launch').glob('*.launch.py'))
PARAMS = REPO / 'config' / 'bridge_params.yaml'
ROS2_CONTROL = REPO / 'examples' / 'ros2_control'
LAUNCH_IMPORTS = {'launch': {'LaunchDescription'}, 'launch.actions': {'DeclareLaunchArgument'},
                  'launch.substitutions': {'LaunchConfiguration', 'PathJoinSubstitution'},
                  'launch_ros.actions': {'Node'}, 'launch_ros.substitutions': {'FindPackageShare'}}


def declared_parameters() -> set[str]:
    return {f.name for f in fields(BridgeParameters)} | {f'record.{name}' for name in recording.DESCRIPTIONS}


def installed_share_files() -> dict[str, Path]:
    """share/drive_bridge/... -> the repository file setup.py installs there."""
    captured: dict = {}
    with mock.patch.object(setuptools, 'setup', lambda **kw: captured.update(kw)), contextlib.chdir(REPO):
        runpy.run_path(str(REPO / 'setup.py'))
    return {f'{dest}/{Path(name).name}': REPO / name for dest, names in captured['data_files'] for name in names}


class LaunchFile:
    """The calls of a launch file, with names bound to a call (``share = FindPackageShare(...)``) resolved."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.tree = ast.parse(path.read_text(), str(path))
        self.bound = {n.targets[0].id: n.value for n in ast.walk(self.tree)
                      if isinstance(n, ast.Assign) and len(n.targets) == 1 and isinstance(n.targets[0], ast.Name)}

    def resolve(self, node: ast.expr) -> ast.expr:
        return self.bound.get(node.id, node) if isinstance(node, ast.Name) else node

    def calls(self, name: str) -> list[ast.Call]:
        return [n for n in ast.walk(self.tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
                and n.func.id == name]

    def first_strings(self, name: str) -> list[str]:
        values = [c.args[0] for c in self.calls(name)]
        assert all(isinstance(v, ast.Constant) and isinstance(v.value, str) for v in values), \
            f'{self.path.name}: {name} with a computed name'
        return [v.value for v in values]  # type: ignore[attr-defined]

    def share_paths(self) -> list[str]:
        """share/drive_bridge/<parts> of each PathJoinSubstitution([FindPackageShare('drive_bridge'), parts...])."""
        paths = []
        for call in self.calls('PathJoinSubstitution'):
            head, *parts = call.args[0].elts  # type: ignore[attr-defined]
            head = self.resolve(head)
            assert isinstance(head, ast.Call) and head.func.id == 'FindPackageShare'  # type: ignore[attr-defined]
            assert ast.literal_eval(head.args[0]) == 'drive_bridge'
            paths.append('share/drive_bridge/' + '/'.join(ast.literal_eval(p) for p in parts))
        return paths

    def keyword(self, call: ast.Call, name: str) -> ast.expr:
        return next(k.value for k in call.keywords if k.arg == name)


@pytest.mark.parametrize('path', LAUNCH_FILES, ids=lambda p: p.name)
def test_launch_file_names_only_what_exists(path: Path) -> None:
    launch = LaunchFile(path)
    for node in ast.walk(launch.tree):
        if isinstance(node, ast.ImportFrom):
            assert node.module in LAUNCH_IMPORTS and {a.name for a in node.names} <= LAUNCH_IMPORTS[node.module]
    assert any(isinstance(n, ast.FunctionDef) and n.name == 'generate_launch_description' for n in launch.tree.body)
    # launch arguments: each one used is declared, each one declared is used
    declared, used = launch.first_strings('DeclareLaunchArgument'), launch.first_strings('LaunchConfiguration')
    assert set(used) == set(declared) and len(declared) == len(set(declared)), (declared, used)
    # files in the package's share directory: installed there by setup.py, from a file in the repository
    installed = installed_share_files()
    for share_path in launch.share_paths():
        assert share_path in installed and installed[share_path].is_file(), share_path
    # nodes: our package and executables, parameters the node declares
    executables = {e.name for e in importlib.metadata.distribution('drive_bridge').entry_points
                   if e.group == 'console_scripts'}
    nodes = launch.calls('Node')
    assert nodes
    for node in nodes:
        assert ast.literal_eval(launch.keyword(node, 'package')) == 'drive_bridge'
        assert ast.literal_eval(launch.keyword(node, 'executable')) in executables
        for item in launch.keyword(node, 'parameters').elts:  # type: ignore[attr-defined]
            item = launch.resolve(item)
            if isinstance(item, ast.Dict):
                names = {ast.literal_eval(k) for k in item.keys if k is not None}
                assert names and names <= declared_parameters(), names - declared_parameters()
            else:  # a parameter file, given by a launch argument
                assert isinstance(item, ast.Call) and item.func.id == 'LaunchConfiguration'  # type: ignore[attr-defined]


@pytest.mark.parametrize('path', LAUNCH_FILES, ids=lambda p: p.name)
def test_launch_description_builds_where_launch_ros_is_installed(path: Path) -> None:
    pytest.importorskip('launch_ros', reason='launch_ros is not on PyPI: the ast test above covers this file')
    description = runpy.run_path(str(path))['generate_launch_description']()
    assert {a.name for a in description.get_launch_arguments()} == set(LaunchFile(path).first_strings(
        'DeclareLaunchArgument'))


def test_launch_files_and_examples_are_installed() -> None:
    installed = installed_share_files()
    for path in [*LAUNCH_FILES, PARAMS, *sorted((REPO / 'examples').rglob('*.*'))]:
        relative = path.relative_to(REPO).as_posix()
        assert f'share/drive_bridge/{relative}' in installed, relative


def test_the_parameter_file_has_every_parameter_at_its_default() -> None:
    text = PARAMS.read_text()
    given = yaml.safe_load(text)['/**']['ros__parameters']
    defaults = {f.name: list(f.default) if isinstance(f.default, tuple) else f.default
                for f in fields(BridgeParameters)}
    assert given == defaults
    # record.*: shown as comments (a value in the file would override the bus configuration's)
    shown = {key: yaml.safe_load(value) for key, value in re.findall(r'^\s*#\s*(record\.\w+):\s*(\S+)', text, re.M)}
    assert shown == {f'record.{name}': getattr(RecordConfig(), name) for name in recording.DESCRIPTIONS}


def demo_node(ros: RosHarness, params_file: Path) -> BusNode:
    text = yaml.safe_dump(demo_data(), sort_keys=False)
    node = BusNode(context=ros.context, cli_args=['--ros-args', '--params-file', str(params_file)],
                   parameter_overrides=[Parameter('config_yaml', value=text)])
    ros.add(node)
    return node


def test_rcl_loads_the_parameter_file_into_the_node(ros: RosHarness, tmp_path: Path) -> None:
    node = demo_node(ros, PARAMS)
    try:
        assert node.params == dataclasses.replace(BridgeParameters(), config_yaml=node.params.config_yaml)
    finally:
        node.close()
    # a copy with values changed as a user would: each reaches the node
    changed = {'qos_depth: 10 ': 'qos_depth: 3 ', 'state_rate: 10.0 ': 'state_rate: 2.5 ',
               'command_joints: [] ': 'command_joints: [elbow_joint, base_joint] ',
               'joint_commands_topic: ~/joint_commands': 'joint_commands_topic: /robot_joint_commands'}
    text = PARAMS.read_text()
    for old, new in changed.items():
        assert old in text
        text = text.replace(old, new)
    mine = tmp_path / 'my_params.yaml'
    mine.write_text(text)
    node = demo_node(ros, mine)
    try:
        assert (node.params.qos_depth, node.params.state_rate) == (3, 2.5)
        assert node.params.command_joints == ('elbow_joint', 'base_joint')
        assert node.params.joint_commands_topic == '/robot_joint_commands'
    finally:
        node.close()


def test_a_params_file_that_sets_config_is_not_the_demo(tmp_path: Path) -> None:
    """A launch file's parameters reach the node as params files: such a node must not get the
    demo's auto_enable, which would override the file's."""
    launch_style = tmp_path / 'launch_params.yaml'
    launch_style.write_text(yaml.safe_dump({'/**': {'ros__parameters': {'config': '/robot/bus.yaml'}}}))
    nested = tmp_path / 'nested.yaml'
    nested.write_text(yaml.safe_dump({'arm': {'drive_bridge': {'ros__parameters': {'config_yaml': 'bus: {}'}}}}))
    assert params_files_set_config(['--ros-args', '--params-file', str(PARAMS), '--params-file', str(launch_style)])
    assert params_files_set_config(['--ros-args', '--params-file', str(nested)])
    assert not params_files_set_config(['--ros-args', '--params-file', str(PARAMS)])  # config: ''
    assert not params_files_set_config(['--ros-args', '--params-file', str(tmp_path / 'missing.yaml')])


def ros2_control_example() -> tuple[dict[str, str], dict[str, tuple[list[str], list[str]]]]:
    """The URDF's hardware parameters, and per joint (command interfaces, state interfaces)."""
    root = ET.parse(ROS2_CONTROL / 'ros2_control.urdf').getroot()
    (system,) = root.iter('ros2_control')
    hardware = system.find('hardware')
    assert hardware is not None and hardware.findtext('plugin') == 'topic_based_ros2_control/TopicBasedSystem'
    params = {p.get('name', ''): p.text or '' for p in hardware.iter('param')}
    joints = {j.get('name', ''): ([c.get('name', '') for c in j.iter('command_interface')],
                                  [s.get('name', '') for s in j.iter('state_interface')])
              for j in system.iter('joint')}
    return params, joints


def test_the_ros2_control_example_names_the_bridges_topics_joints_and_interfaces() -> None:
    params, joints = ros2_control_example()
    bridge = yaml.safe_load((ROS2_CONTROL / 'bridge_params.yaml').read_text())['/**']['ros__parameters']
    assert set(bridge) <= declared_parameters()
    # ~/joint_commands of the node /drive_bridge; its joint states where the URDF reads them
    assert params['joint_commands_topic'] == bridge['joint_commands_topic'].replace('~', '/drive_bridge')
    assert params['joint_states_topic'] == bridge['joint_states_topic'] != '/joint_states'
    demo_joints = [a['joint'] for n in demo_data()['nodes'].values() for a in n['axes']]
    assert list(joints) == demo_joints
    controllers = yaml.safe_load((ROS2_CONTROL / 'controllers.yaml').read_text())
    manager = controllers['controller_manager']['ros__parameters']
    assert manager['joint_state_broadcaster']['type'] == 'joint_state_broadcaster/JointStateBroadcaster'
    assert manager['arm_controller']['type'] == 'joint_trajectory_controller/JointTrajectoryController'
    arm = controllers['arm_controller']['ros__parameters']
    assert arm['joints'] == demo_joints
    for commands, states in joints.values():
        assert set(arm['command_interfaces']) <= set(commands) and set(arm['state_interfaces']) <= set(states)
        assert set(states) <= {'position', 'velocity', 'effort'}  # the fields of the bridge's JointState


def test_the_ros2_control_topics_drive_the_demo(ros: RosHarness) -> None:
    """What TopicBasedSystem does: JointState commands on joint_commands_topic every update, joint
    states read from joint_states_topic."""
    params, joints = ros2_control_example()
    node = demo_node(ros, ROS2_CONTROL / 'bridge_params.yaml')
    try:
        node.master.wait_until_operational(10.0)
        for joint, (commands, _) in joints.items():  # each joint in the mode whose field the URDF commands
            assert node.master.axes[joint].command_field() == commands[0], joint
        client = ros.node('ros2_control_enable').create_client(AxisCommand, '/drive_bridge/enable')
        assert ros.call(client, AxisCommand.Request(joints=[]), timeout=15.0).success
        states: list[JointState] = []
        hardware = ros.node('topic_based_system')
        hardware.create_subscription(JointState, params['joint_states_topic'], states.append, 100)
        commands_out = hardware.create_publisher(JointState, params['joint_commands_topic'], 10)
        latest = wait_for(lambda: states[-1] if states else None, 10, 'joint states on the URDF topic')
        start = dict(zip(latest.name, latest.position))
        assert set(start) == set(joints)
        # 100 Hz for 0.5 s, a ramp to start + step: each command a step the cycle check allows in one
        # 4 ms cycle (lift_joint: max_velocity 0.2 m/s, so at most 0.8 mm per command)
        step = 0.03
        for i in range(1, 51):
            commands_out.publish(JointState(name=list(joints), position=[start[j] + step * i / 50 for j in joints]))
            time.sleep(0.01)
        for joint in joints:
            wait_for(lambda j=joint: abs(node.master.axes[j].snapshot().position - start[j] - step) < 2e-3, 5,
                     f'{joint} at the commanded position')
        assert dict(zip(states[-1].name, states[-1].position)).keys() == set(joints)
    finally:
        node.close()
