"""One CAN bus: the drive_bridge node with its bus configuration and ROS parameters.

    ros2 launch drive_bridge bridge.launch.py                        # the demo's simulated drives
    ros2 launch drive_bridge bridge.launch.py config:=/path/to/bus.yaml namespace:=arm
    ros2 launch drive_bridge bridge.launch.py params_file:=/path/to/my_params.yaml

The node is /<namespace>/drive_bridge: its action is <namespace>/drive_bridge/follow_joint_trajectory
(MoveIt: examples/moveit/moveit_controllers.yaml). Joint states go to /joint_states whatever
the namespace (parameter joint_states_topic). For the lifecycle node use executable
bridge_managed. test/test_launch_files.py checks what this file names (docs/hardware.md).
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare


def generate_launch_description() -> LaunchDescription:
    share = FindPackageShare('drive_bridge')
    return LaunchDescription([
        DeclareLaunchArgument('config', default_value=PathJoinSubstitution([share, 'config', 'demo.yaml']),
                              description='bus configuration YAML (docs/configuration.md); default: the demo'),
        DeclareLaunchArgument('namespace', default_value='', description='namespace of the node'),
        DeclareLaunchArgument('params_file',
                              default_value=PathJoinSubstitution([share, 'config', 'bridge_params.yaml']),
                              description='ROS parameters of the node; default: every parameter at its default'),
        Node(package='drive_bridge', executable='bridge', name='drive_bridge',
             namespace=LaunchConfiguration('namespace'),
             parameters=[LaunchConfiguration('params_file'), {'config': LaunchConfiguration('config')}],
             output='screen', emulate_tty=True),
    ])
