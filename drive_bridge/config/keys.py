"""Every key the loader knows, per section, and the other tools' keys it accepts
with a warning. One place, so docs/configuration.md and the checks agree."""
from __future__ import annotations

TOP = ('bus', 'master', 'options', 'defaults', 'nodes', 'simulation', 'access', 'record', 'trajectory')
BUS = ('interface', 'channel', 'bitrate', 'options', 'allow_overload')
OPTIONS = ('dcf_path', 'heartbeat_multiplier')
MASTER = ('node_id', 'sync_period', 'sync_producer', 'heartbeat_producer', 'heartbeat_consumer',
          'heartbeat_multiplier', 'baudrate', 'sync_window', 'realtime_priority')
SIMULATION = ('enabled', 'nodes')
RECORD = ('path', 'split_size_mb', 'split_seconds', 'start')
TRAJECTORY = ('scale_to_limits',)

_ROS_COMPONENT = 'ros2_canopen component setting; drive_bridge runs no ros2_canopen components'
_LELY_MASTER = 'lely master DCF setting; drive_bridge configures its master from this file itself'
MASTER_IGNORED: dict[str, str] = {
    'driver': _ROS_COMPONENT, 'package': _ROS_COMPONENT, 'namespace': _ROS_COMPONENT,
    'remappings': _ROS_COMPONENT,
    **{key: 'master identity (0x1018) of a lely master; drive_bridge does not publish one'
       for key in ('vendor_id', 'product_code', 'revision_number', 'serial_number')},
    **{key: _LELY_MASTER for key in ('emcy_inhibit_time', 'sync_overflow', 'error_behavior',
                                     'nmt_inhibit_time', 'start', 'start_nodes', 'start_all_nodes',
                                     'reset_all_nodes', 'stop_all_nodes', 'boot_time')},
    'boot_timeout': 'ros2_canopen wait for its master process; use boot_timeout_ms per node',
}

IDENTITY = ('device_type', 'vendor_id', 'product_code', 'revision_number', 'serial_number')
TIMEOUTS_MS = ('boot_timeout_ms', 'boot_retry_interval_ms', 'sdo_timeout_ms', 'state_switch_timeout_ms',
               'mode_switch_timeout_ms', 'homing_timeout_ms', 'command_timeout_ms')
RETRIES = ('boot_retries', 'sdo_retries')
MODE_KEYS = ('position_mode', 'velocity_mode', 'effort_mode')
LINEAR_SCALING = ('scale_pos_to_dev', 'scale_pos_from_dev', 'offset_pos_to_dev', 'offset_pos_from_dev',
                  'scale_vel_to_dev', 'scale_vel_from_dev', 'scale_eff_from_dev')
CHANNEL_FORM = ('num_channels', 'channel_names', 'channels')
# keys of the ros2_canopen way to declare axes (instead of an `axes` list)
ROS_AXIS_FORM = CHANNEL_FORM + LINEAR_SCALING + MODE_KEYS
NODE = ('node_id', 'family', 'driver', 'dcf', 'dcf_path', *IDENTITY, 'sdo', 'rpdo', 'tpdo',
        'heartbeat_producer', 'heartbeat_consumer', 'guard_time_ms', 'life_time_factor', 'reset_communication',
        *TIMEOUTS_MS,
        'homing_timeout_seconds', *RETRIES, 'axes', *ROS_AXIS_FORM)

_ROS_NODE = 'ros2_canopen driver setting with no meaning in drive_bridge'
_LELY_NODE = 'lely DCF/boot setting that drive_bridge does not implement'
NODE_IGNORED: dict[str, str] = {
    **{key: _ROS_COMPONENT for key in ('package', 'namespace', 'remappings')},
    **{key: _ROS_NODE for key in ('polling', 'period', 'diagnostics', 'enable_lazy_load',
                                  'non_transmit_timeout', 'switching_state')},
    **{key: _LELY_NODE for key in ('boot', 'mandatory', 'software_file', 'software_version',
                                   'configuration_file', 'restore_configuration', 'error_behavior')},
    'heartbeat_multiplier': 'per-node multiplier; drive_bridge uses master.heartbeat_multiplier for all nodes',
}

AXIS = ('joint', 'slot', 'type', 'mode', *MODE_KEYS, 'interpolation', 'scaling', 'limits', 'homing',
        'position_loop', 'on_node_loss', 'drive')
NODE_LOSS = ('action', 'brake_delay')
POSITION_LOOP = ('gain', 'following_error')
PHYSICAL_SCALING = ('counts_per_revolution', 'counts_per_metre', 'gear_ratio', 'direction', 'offset',
                    'velocity_scale', 'rated_torque')
SCALING = PHYSICAL_SCALING + LINEAR_SCALING
LIMITS = ('min_position', 'max_position', 'max_velocity', 'max_acceleration', 'max_effort', 'on_violation')
VIOLATION_REACTIONS = ('halt', 'quick_stop')
# a placeholder value of a starter config: the key (or whole scaling/limits section, or dcf) is
# still to be filled; `scaling: none` declines scaling (device units) on purpose
TODO = 'TODO'
NO_SCALING = 'none'
HOMING = ('method', 'speed_search', 'speed_zero', 'acceleration', 'offset')

PDO_COMMON = ('enabled', 'cob_id', 'transmission', 'transmission_type', 'event_timer', 'mapping')
RPDO = PDO_COMMON
TPDO = PDO_COMMON + ('inhibit_time', 'sync_start')
RPDO_IGNORED = {'event_deadline': 'lely RPDO deadline extension; drive_bridge does not monitor RPDO deadlines'}
MAPPING_ENTRY = ('index', 'sub_index', 'subindex')
SDO_ITEM = ('index', 'sub_index', 'subindex', 'value')

# ros2_canopen `driver:` values and the family that does the same job here
DRIVER_FAMILIES: dict[str, str] = {
    'ros2_canopen::Cia402Driver': 'generic_402',
    'ros2_canopen::LifecycleCia402Driver': 'generic_402',
    'ros2_canopen::MotionControllerDriver': 'generic_402',  # the 402 driver's name before 0.2
    'ros2_canopen::LifecycleMotionControllerDriver': 'generic_402',
    'ros2_canopen::ProxyDriver': 'generic_301',
    'ros2_canopen::LifecycleProxyDriver': 'generic_301',
}

# ros2_canopen's values for scale keys a node omits (canopen_402_driver)
ROS_SCALING_DEFAULTS: dict[str, float] = {
    'scale_pos_from_dev': 0.001, 'scale_vel_from_dev': 0.001, 'scale_eff_from_dev': 0.001,
    'offset_pos_from_dev': 0.0,
}
