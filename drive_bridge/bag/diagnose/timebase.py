"""Is the log's time base the bus's own? A pasted screen output has no time stamps (every
frame at 0), and logs converted by tools that number their frames get synthetic ones (every
frame exactly n x 1 ms after the last): both give false heartbeat, SYNC and PDO timing
findings. Judged on the first frames; a real clock never steps in exact milliseconds."""
from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from drive_bridge.bag.candump import RawFrame

TIMEBASE_FRAMES = 4096
SYNTHETIC_MIN = 20  # intervals needed to call a time base synthetic
SYNTHETIC_SHARE = 0.9  # ... when this share of the intervals is one exact value


def timebase(head: Sequence[RawFrame]) -> str:
    """'recorded', 'none' or 'synthetic (every frame 1 ms after the last)'."""
    if len(head) >= 2 and all(f[0] == head[0][0] for f in head):
        return 'none'
    steps = [round((b[0] - a[0]) * 1e6) for a, b in zip(head, head[1:])]
    if len(steps) < SYNTHETIC_MIN:
        return 'recorded'
    (step, count), = Counter(steps).most_common(1)
    # numbered frames: nearly every step is the one exact millisecond value, none shorter; on a real
    # bus a response, a PDO after its SYNC, a burst come micro- to sub-milliseconds apart
    shorter = sum(1 for s in steps if s < step)
    if step > 0 and step % 1000 == 0 and count >= SYNTHETIC_SHARE * len(steps) and shorter <= 0.01 * len(steps):
        return f'synthetic (every frame {step / 1000:g} ms after the last)'
    return 'recorded'
