"""drive_bridge: an ament_python package, also installable with pip."""
from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'drive_bridge'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(include=[PACKAGE, f'{PACKAGE}.*']),
    package_data={PACKAGE: ['py.typed', 'families/*/data/*']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/config', glob('config/*.yaml')),
        (f'share/{PACKAGE}/launch', glob('launch/*.launch.py')),
        (f'share/{PACKAGE}/examples/moveit', glob('examples/moveit/*')),
        (f'share/{PACKAGE}/examples/ros2_control', glob('examples/ros2_control/*')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='drive_bridge developers',
    maintainer_email='dev@drive-bridge.org',
    description='ROS 2 bridge for CANopen CiA 402 servo drives',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            f'bridge = {PACKAGE}.cli:bridge_main',
            f'drive-bridge = {PACKAGE}.cli.main:console_main',
            f'bridge_managed = {PACKAGE}.cli:bridge_managed_main',
        ],
        'can.interface': [f'local = {PACKAGE}.transport.local:LocalBus'],
    },
)
