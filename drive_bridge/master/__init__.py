"""The CANopen master side of the core: bus, network, boot, SDO, NMT, EMCY, SYNC."""
