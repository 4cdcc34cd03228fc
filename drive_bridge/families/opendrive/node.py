"""One OPEN drive at run time: its axis' driver (:class:`~.driver.RunLogicDriver`), which the
boot steps (:mod:`~.boot`) give the feedback's scaling and the logic word, the stop of a drive
that runs on without its master, and the parameter access."""
from __future__ import annotations

from collections.abc import Sequence

from drive_bridge.families.errors import ParameterError
from drive_bridge.families.node import FamilyNode, NodeFamily
from drive_bridge.families.opendrive import boot
from drive_bridge.families.opendrive.driver import RunLogicDriver
from drive_bridge.families.opendrive.parameters import OpenDriveParameters
from drive_bridge.families.opendrive.units import Units
from drive_bridge.families.parameters import ParameterPort
from drive_bridge.families.ports import BootStep, NodePort
from drive_bridge.joint import JointDriver, NodeIo
from drive_bridge.model import AxisConfig, NodeConfig, Timeouts


class OpenDriveNode(FamilyNode):
    """One OPEN drive node (one axis)."""

    def __init__(self, family: NodeFamily, config: NodeConfig) -> None:
        super().__init__(family, config)
        self.driver: RunLogicDriver | None = None

    def create_joint_driver(self, node: NodeIo, axis: AxisConfig, timeouts: Timeouts,
                            cycle_period: float) -> JointDriver:
        self.driver = RunLogicDriver(node, axis, timeouts, cycle_period, family=self.family.name)
        return self.driver

    def stop_run_on(self, by_sdo: bool) -> bool:
        """RUN low and references 0 (the driver's outputs; by SDO too), at rest when the speed is 0."""
        return True if self.driver is None else self.driver.stop_run_on(by_sdo)

    # -- boot ----------------------------------------------------------------------------------
    def boot_steps_before(self, node: NodePort) -> Sequence[BootStep]:
        return (('RUN low, references 0', boot.stop_drive), ('C52 = 1 (CAN references)', boot.check_c52),
                ('representation words 0x2003 / 0x2004', self._read_representations))

    def boot_steps_after(self, node: NodePort) -> Sequence[BootStep]:
        return (('life time within 32767/f_pwm', boot.clamp_life_time),
                ('logic word 0x201F as the drive has it', self._read_logic_word))

    def _read_representations(self, node: NodePort) -> None:
        scaling = boot.read_representations(node)
        if self.driver is not None:
            self.driver.units = Units(boot.options_of(node), scaling)

    def _read_logic_word(self, node: NodePort) -> None:
        word = boot.read_logic_word(node)
        if self.driver is not None:
            self.driver.set_logic_word(word)

    # -- parameters ----------------------------------------------------------------------------
    def parameters(self, port: ParameterPort) -> OpenDriveParameters:
        """P and C parameters by number (0x200D / 0x200E) with their format words."""
        config: NodeConfig | None = getattr(port, 'config', None)
        if self.driver is not None:
            offset = self.driver.options.array_offset
        elif config is not None and config.axes and 'array_offset' in config.axes[0].drive:
            offset = int(config.axes[0].drive['array_offset'])
        else:
            raise ParameterError(f'node {port.node_id} ({port.name}): the sub-index offset of the parameter arrays '
                                 '(the axis drive setting array_offset) is unknown', node_id=port.node_id)
        return OpenDriveParameters(port, offset)
