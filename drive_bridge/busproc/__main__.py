"""``python -m drive_bridge.busproc``: the bus process (started by the node process)."""
import logging
import os
import sys

from drive_bridge.busproc.process import main

code = main()
logging.shutdown()
sys.stdout.flush()
sys.stderr.flush()
# not a normal interpreter exit: that joins every worker thread, and a request still waiting on a
# drive (an intent with a long timeout) would keep the process, and its bus, alive
os._exit(code)
