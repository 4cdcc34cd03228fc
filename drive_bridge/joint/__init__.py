"""The joint-driver protocol: what the ROS layer, streaming, services and diagnostics see of
one drive axis, whatever profile the drive speaks (CiA 402 or a family's own logic)."""
from drive_bridge.joint.driver import BufferFeeder, JointDriver, Setpoint, SetpointSource
from drive_bridge.joint.errors import JointError
from drive_bridge.joint.nodeio import NodeIo
from drive_bridge.joint.snapshot import AxisSnapshot, DriveState

__all__ = ['AxisSnapshot', 'BufferFeeder', 'DriveState', 'JointDriver', 'JointError', 'NodeIo', 'Setpoint',
           'SetpointSource']
