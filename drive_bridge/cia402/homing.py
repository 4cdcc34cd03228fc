"""The homing parameters of one axis from its configuration: method 0x6098, speeds 0x6099,
acceleration 0x609A and home offset 0x607C, written by SDO before a homing starts."""
from __future__ import annotations

from drive_bridge.cia402 import objects as obj
from drive_bridge.joint import NodeIo
from drive_bridge.model import AxisConfig


def write_homing_parameters(node: NodeIo, config: AxisConfig) -> None:
    """Homing method, speeds, acceleration and offset from the config, where given (SDO)."""
    homing, scaling, slot = config.homing, config.scaling, config.slot
    velocity = (lambda si: abs(scaling.velocity_to_device(si)))
    writes = ((obj.HOMING_METHOD, 0, homing.method, int),
              (obj.HOMING_SPEEDS, 1, homing.speed_search, velocity),
              (obj.HOMING_SPEEDS, 2, homing.speed_zero, velocity),
              (obj.HOMING_ACCELERATION, 0, homing.acceleration, velocity),
              (obj.HOME_OFFSET, 0, homing.offset,
               lambda si: round(si / scaling.position_factor)))
    for index, subindex, value, convert in writes:
        if value is not None:
            node.sdo_write(obj.for_axis(index, slot), subindex, convert(value))
