"""``python -m drive_bridge.busproc``: the bus process (started by the node process)."""
from drive_bridge.busproc.process import main

raise SystemExit(main())
