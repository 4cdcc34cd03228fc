"""CiA 301 vocabulary the core shares: NMT states and EMCY decoding (pure, no bus)."""
