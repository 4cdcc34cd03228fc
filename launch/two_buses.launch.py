"""Two CAN buses, one drive_bridge node each (a node owns one bus; docs/hardware.md).

    ros2 launch drive_bridge two_buses.launch.py
    ros2 launch drive_bridge two_buses.launch.py arm_config:=arm.yaml gantry_config:=gantry.yaml

Defaults: the demo's four joints as /arm/drive_bridge and the SERVOSTAR example's two as
/gantry/drive_bridge, each on its own simulated bus. Both publish /joint_states (each message
carries its own bus's joints, as robot_state_publisher takes them); MoveIt sees two controllers,
arm/drive_bridge and gantry/drive_bridge. One params_file serves both nodes (`/**`); what
differs between the buses lives in their bus configurations. test/test_launch_files.py checks
what this file names.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare


def generate_launch_description() -> LaunchDescription:
    share = FindPackageShare('drive_bridge')
    params = LaunchConfiguration('params_file')
    return LaunchDescription([
        DeclareLaunchArgument('arm_config', default_value=PathJoinSubstitution([share, 'config', 'demo.yaml']),
                              description='bus configuration YAML of the arm bus'),
        DeclareLaunchArgument('gantry_config',
                              default_value=PathJoinSubstitution([share, 'config', 'servostar_example.yaml']),
                              description='bus configuration YAML of the gantry bus'),
        DeclareLaunchArgument('params_file',
                              default_value=PathJoinSubstitution([share, 'config', 'bridge_params.yaml']),
                              description='ROS parameters of both nodes'),
        Node(package='drive_bridge', executable='bridge', name='drive_bridge', namespace='arm',
             parameters=[params, {'config': LaunchConfiguration('arm_config')}],
             output='screen', emulate_tty=True),
        Node(package='drive_bridge', executable='bridge', name='drive_bridge', namespace='gantry',
             parameters=[params, {'config': LaunchConfiguration('gantry_config')}],
             output='screen', emulate_tty=True),
    ])
