"""A simulated Kollmorgen AKD (family ``akd``): the generic CiA 402 drive with the AKD's
own rules where a master can observe them (manual rev. F as summarised in
shared/drives/akd.md; numbers in brackets are its sections).

Modules: objects (indices, codes, fixed values), emcy (category byte, warnings), pdo (PDO
rules), sdo (expedited downloads of another size), pvt (interpolation buffer, Hermite,
interpolated position mode), homing, axis (the axis), drive (the node: :class:`SimAkd`,
registered as the ``akd`` simulator on import).

Interpolated position mode (0x6060 = 7), enabled by controlword bit 4 (statusword bit 12):

- PVT (0x60C0 = -2) [5.3, 5.8]: a point is taken once 0x60C1 subs 1 (absolute position,
  counts), 2 (time in ms to reach it from the previous point) and 3 (velocity at the point,
  counts/s, times 0x204C:1 / 0x204C:2) have all been written since the last point, by
  RPDO or SDO. RPDOs received between two SYNCs are applied at the SYNC in COB-ID order
  (the manual's map: 0x301 = position + time, 0x401 = velocity). The drive runs a cubic
  Hermite from its current point to the next over that time; the first segment of a motion
  starts at the actual position (with the demand velocity, 0 at rest) at the SYNC that
  brought the point; a point with time 0 ends the motion: the axis stops at the last
  position (its own position and velocity fields are ignored) and statusword bit 10 is set
  at standstill.
- Buffer [5.5]: 0x60C4:1 = 10, of which 9 places are usable; a point occupies its place
  until the axis reaches it (the point being approached counts), so 0x60C4:2 reads 9 when
  empty, 8 while one segment runs and nothing is queued, 0 when full.
- n704 overflow [5.6]: a point arriving while the buffer is full is dropped; warning n704,
  EMCY 0x8584 (once per occurrence: not again while the warning stays).
- n705 underflow [5.6]: the running segment ends, no point follows and no end point came:
  warning n705, EMCY 0x8585; the axis brakes from the segment's end velocity to standstill
  with the controlled-stop ramp 0x3440:1 CS.DEC and holds there, still enabled. A new point
  starts a new motion from the actual position.
- Warnings (the manual does not say how they are reset): statusword bit 7 and 0x1002 bit 8
  while any is active; they clear when a point is accepted into the buffer, when the buffer
  is cleared (0x60C4:6 = 0) and when the axis leaves interpolated position mode or
  Operation Enabled. No EMCY is sent when a warning clears. A warning's EMCY carries the
  error register as it is (faults only) and category 1.
- Linear (0x60C0 = 0) [5.7]: only 0x60C1:1, one point per SYNC, reached linearly over the
  interpolation period 0x60C2; 0x60C4:5 accepts only 1; an empty buffer holds the last point
  (no warning); statusword bit 10 is never set (the manual's example shows 0x1237 at rest).
- 0x60C0 = -1 ("reserved") is refused (0x06090030); writing the sub-mode empties the buffer.
- 0x60C2 [5.4]: a new period takes effect once both sub-indices have been written; a pair
  that is not a whole number of ms is refused at its second write (0x06090030) and both must
  be written again. Power-on: 1 ms.
- Controlword bit 4 falling, a halt, a quick stop, a buffer clear: the running segment is
  abandoned and the axis brakes (profile / DRV.DEC ramp; quick stop: CS.DEC). Queued points
  are kept on bit 4 falling and on a halt (released, the axis restarts toward the point it
  was approaching, over that point's full time); they are dropped on a quick stop, on
  leaving Operation Enabled and on a mode change.

Other quirks [10]:

- 0x6502 = 0x65 (pp, pv, hm, ip), yet 0x6060 accepts 1, 3, 4, 6, 7, 8; every other value,
  CSV (9) and CST (10) included, is refused with 0x06090030 [4.6].
- A mode change takes effect at the drive's next cycle (the next SYNC, or its own 10 ms
  clock without SYNC): 0x6061 confirms it, a master must wait for it [4.6].
- Statusword bit 9 (remote) follows FBUS.REMOTE (:meth:`SimAkd.set_remote`); while it is 0
  the controlword is stored but not obeyed [4.3, 10.3].
- No option codes 0x605A-0x605E [4.4]: quick stop brakes on CS.DEC and stays in Quick Stop
  Active (bit 2 set again resumes, transition 16) and cancels the set-points [4.1] (0x60FF
  and 0x6071 read 0, a PP target and the IP buffer are dropped); disable operation ramps
  (profile / DRV.DEC ramp) then switches off; shutdown and disable voltage switch off at
  once; halt brakes on the profile ramp; a fault reaction brakes on CS.DEC. 0x6083/0x6084 = 0 (their default)
  mean DRV.ACC 0x3501 / DRV.DEC 0x3522; 0x609A = 0 means DRV.ACC; the in-position window is
  MT.TPOSWND 0x35C6; 0x6065 = 0 switches following-error monitoring off (F439, 0x8611).
- Expedited SDO downloads whose size differs from the object are accepted [10.15, 12]: more
  bytes than the object are truncated (the rest ignored); fewer are zero- or sign-extended,
  unless a byte beyond the indicated size is not zero, in which case the object's own length
  is read from the frame (the manual's ``2B 8F 60 01 00 00 10 00`` then sets 0x608F:1 to
  2^20, the value the manual says it writes). Segmented transfers must match the size.
- NMT [2.2]: start, stop, reset node, reset communication. Enter Pre-Operational (0x80) is
  not one of the AKD's commands and is ignored (an NMT command cannot be refused).
- PDOs [2.4, 10.12]: transmission types 0..240 and 255 only (241..254 refused with
  0x06090030); RPDO type n applies the data at every n-th SYNC (0: at the next); mapping
  is refused in OPERATIONAL (0x08000022, "map before NMT start"); before that the mapping
  and the COB-ID of a valid PDO may be changed directly, as the manual's examples do
  (§7.2.1.8, §7.2.2.1). Event-driven TPDO1..4 are filtered by the change masks 0x2014-0x2017.
- 0x1016 has one entry [2.8]; a lost heartbeat or node guarding (RTR on 0x700 + node,
  toggle bit, monitoring from the first RTR, time 0x100C x 0x100D [2.7]) raises F129:
  EMCY 0x8130, the axis brakes to standstill (fault reaction) and stays in Fault until the
  master is back and the fault is reset [10.16].
- FBUS.PARAM04 (0x36E8) = 1: with the axis enabled in ip or csp, three missing SYNC periods
  (0x60C2) raise F125, EMCY 0x8780 [1.6].
- EMCY frames [2.6]: byte 3 ("category") is 1 in every error or warning frame, 0 in the
  reset frame; bytes 4..7 are 0. 0x1003 keeps 10 entries.
- 0x1010:1 "save" (0x65766173) makes the present values the power-on values; 0x1011:1
  "load" (0x64616F6C) reloads the saved drive parameters (0x2000 and up); other values are
  refused with 0x08000020; both read 1. Software limits 0x607D take effect at the next
  power-on or NMT reset node [10.14].
- Units: the simulated drive is set up with position user units = counts, so 0x6063 = 0x6064
  and 0x606C is in counts/s; the manual's "0x606C in rpm over PDO" is reproduced only with
  the simulation option ``velocity_pdo_rpm: 1`` (the manual's own PDO example, §7.2.1.5,
  shows 0x1AABA6 for a 0x4000 set-point, which is neither).
"""

from drive_bridge.sim.akd.axis import AkdAxis
from drive_bridge.sim.akd.drive import AKD_OPTIONS, SimAkd
from drive_bridge.sim.akd.emcy import AkdEmcy
from drive_bridge.sim.akd.pdo import AkdPdoEngine
from drive_bridge.sim.akd.pvt import AkdInterpolation, AkdIpBuffer, Hermite, PvtPoint

__all__ = ['AKD_OPTIONS', 'AkdAxis', 'AkdEmcy', 'AkdInterpolation', 'AkdIpBuffer', 'AkdPdoEngine', 'Hermite',
           'PvtPoint', 'SimAkd']
