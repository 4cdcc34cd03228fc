"""What a master meets on an AKD and not on a generic CiA 402 drive (akd.md §10), against the
simulated AKD, through raw CAN frames: modes, NMT, SDO sizes, heartbeat and node guarding,
the remote bit, the interpolation period, PDO rules, quick stop, SYNC supervision, save."""
from __future__ import annotations

import time

from akdtools import RawMaster, Sniffer, akd_bus, h

NODE = 1


def abort(index: int, subindex: int, code: int) -> bytes:
    return bytes([0x80]) + index.to_bytes(2, 'little') + bytes([subindex]) + code.to_bytes(4, 'little')


def wait_upload(m: RawMaster, index: int, subindex: int, expected: str, timeout: float = 1.0) -> None:
    deadline = time.monotonic() + timeout
    while (got := m.upload(NODE, index, subindex)) != h(expected):
        assert time.monotonic() < deadline, f'0x{index:04X}:{subindex} reads {got.hex(" ")}, expected {expected}'
        time.sleep(0.005)


def enable(m: RawMaster, sniffer: Sniffer) -> None:
    """NMT start, then shutdown, switch on, enable operation on RPDO1 (factory map, event-driven)."""
    mark = m.send(0x000, bytes([0x01, NODE]))
    m.expect(0x181, '40 02', after=mark)
    for controlword in ('06 00', '07 00', '0F 00'):
        m.send(0x201, h(controlword))
    deadline = time.monotonic() + 1.0
    while not any(int.from_bytes(f.data[:2], 'little') & 0x6F == 0x27 for f in sniffer.frames(0x181, after=mark)):
        assert time.monotonic() < deadline, 'not Operation Enabled'
        time.sleep(0.005)


def test_modes_advertised_accepted_and_refused() -> None:
    with akd_bus(NODE) as (_bench, _sniffer, m, _sims):
        assert m.upload(NODE, 0x6502) == h('43 02 65 00 65 00 00 00'), 'pp, pv, hm, ip only'
        for mode in (4, 8, 1, 3, 6, 7):  # torque and csp are accepted although not advertised
            m.download(NODE, f'2F 60 60 00 {mode:02X} 00 00 00')
            wait_upload(m, 0x6061, 0, f'4F 61 60 00 {mode:02X} 00 00 00')  # confirmed by 0x6061
        for mode in (9, 10, 2, 5, 0, 0xF8):  # csv, cst, vl, reserved, none, manufacturer -8
            assert m.sdo(NODE, h(f'2F 60 60 00 {mode:02X} 00 00 00')) == abort(0x6060, 0, 0x06090030)
        assert m.upload(NODE, 0x6061) == h('4F 61 60 00 07 00 00 00'), 'the refused writes changed nothing'


def test_only_four_nmt_commands() -> None:
    with akd_bus(NODE) as (_bench, sniffer, m, _sims):
        m.download(NODE, '2B 17 10 00 0A 00 00 00')  # heartbeat every 10 ms
        mark = sniffer.mark
        m.expect(0x701, '7F', after=mark)
        for command, state in (('01', '05'), ('80', '05'), ('02', '04'), ('80', '04'), ('01', '05')):
            mark = m.send(0x000, h(f'{command} 01'))
            beats = [f.data.hex() for f in sniffer.wait(0x701, mark, count=3)]
            assert set(beats[1:]) == {state.lower()}, f'after {command}: {beats}'  # the first may cross
        mark = m.send(0x000, h('82 01'))  # reset communication: boot-up; 0x1017 back to 0
        m.expect_later(0x701, '00', after=mark)  # (a heartbeat may still cross the NMT frame)
        assert m.upload(NODE, 0x1017) == h('4B 17 10 00 00 00 00 00')


def test_expedited_downloads_of_another_size() -> None:
    with akd_bus(NODE) as (_bench, _sniffer, m, _sims):
        m.download(NODE, '2F 4C 20 01 FE 00 00 00')  # 1 byte to an INTEGER32: sign-extended
        assert m.upload(NODE, 0x204C, 1) == h('43 4C 20 01 FE FF FF FF')
        m.download(NODE, '23 02 14 02 05 03 00 00')  # 4 bytes to an UNSIGNED8: the rest ignored
        assert m.upload(NODE, 0x1402, 2) == h('4F 02 14 02 05 00 00 00')
        m.download(NODE, '2B 8F 60 01 00 00 10 00')  # the manual's 2-byte write of 2^20
        assert m.upload(NODE, 0x608F, 1) == h('43 8F 60 01 00 00 10 00')
        m.download(NODE, '2F C2 60 02 FD 00 00 00')  # INTEGER8 -3 (the manual's frame)
        assert m.upload(NODE, 0x60C2, 2) == h('4F C2 60 02 FD 00 00 00')
        assert m.sdo(NODE, h('2F 4C 20 02 00 00 00 00')) == abort(0x204C, 2, 0x06090030), 'pv scaling 0'
        assert m.sdo(NODE, h('40 09 10 00 00 00 00 00')) == abort(0x1009, 0, 0x06020000), 'no 0x1009 yet'
        assert m.sdo(NODE, h('40 85 60 00 00 00 00 00')) == abort(0x6085, 0, 0x06020000), 'no 0x6085'


def test_heartbeat_consumer_has_one_entry_and_its_loss_is_f129() -> None:
    with akd_bus(NODE) as (bench, sniffer, m, _sims):
        assert m.upload(NODE, 0x1016, 0) == h('4F 16 10 00 01 00 00 00')
        assert m.sdo(NODE, h('40 16 10 02 00 00 00 00')) == abort(0x1016, 2, 0x06090011)
        m.download(NODE, '23 16 10 01 32 00 7F 00')  # master 127, 50 ms
        enable(m, sniffer)
        for _ in range(5):
            bench.send(0x77F, b'\x05')
            time.sleep(0.02)
        mark = sniffer.mark  # the master falls silent
        m.expect(0x081, '30 81 11 01 00 00 00 00', after=mark, timeout=1.0)  # F129: communication + generic
        m.expect_later(0x181, '08 02', after=mark)  # braked, then Fault
        m.send(0x201, h('80 00'))  # fault reset while the master is still missing: refused
        time.sleep(0.03)
        assert m.upload(NODE, 0x6041)[4:6] == h('08 02')
        bench.send(0x77F, b'\x05')
        time.sleep(0.02)
        mark = sniffer.mark
        m.send(0x201, h('00 00'))
        m.send(0x201, h('80 00'))
        m.expect(0x081, '00 00 00 00 00 00 00 00', after=mark)
        m.expect_later(0x181, '40 02', after=mark)


def test_node_guarding_toggles_and_its_loss_is_f129() -> None:
    with akd_bus(NODE) as (bench, sniffer, m, _sims):
        m.download(NODE, '2B 0C 10 00 14 00 00 00')  # guard time 20 ms
        m.download(NODE, '2F 0D 10 00 03 00 00 00')  # life time factor 3: 60 ms
        replies = []
        for _ in range(2):
            mark = sniffer.mark
            bench.master.send_message(0x701, b'', remote=True)
            replies += [f.data for f in sniffer.wait(0x701, mark, count=2) if not f.remote]
        enable(m, sniffer)
        mark = sniffer.mark
        bench.master.send_message(0x701, b'', remote=True)
        replies += [f.data for f in sniffer.wait(0x701, mark, count=2) if not f.remote]
        assert replies == [h('7F'), h('FF'), h('05')], 'state with the toggle bit'
        mark = sniffer.mark  # no more guarding requests
        m.expect(0x081, '30 81 11 01 00 00 00 00', after=mark, timeout=1.0)


def test_remote_bit_and_control_by_another_channel() -> None:
    with akd_bus(NODE) as (_bench, _sniffer, m, sims):
        assert m.upload(NODE, 0x6041)[4:6] == h('40 02')
        sims[0].set_remote(False)  # WorkBench took over (FBUS.REMOTE = 0)
        assert m.upload(NODE, 0x6041)[4:6] == h('40 00')
        m.download(NODE, '2B 40 60 00 06 00 00 00')  # accepted, not obeyed
        assert m.upload(NODE, 0x6041)[4:6] == h('40 00')
        sims[0].set_remote(True)
        m.download(NODE, '2B 40 60 00 06 00 00 00')
        assert m.upload(NODE, 0x6041)[4:6] == h('31 02')


def test_interpolation_period_needs_both_subindices_in_whole_ms() -> None:
    with akd_bus(NODE) as (_bench, _sniffer, m, sims):
        axis = sims[0].axis_akd
        assert axis.interpolation_period() == 0.001
        m.download(NODE, '2F C2 60 01 19 00 00 00')  # 25 ...
        assert m.sdo(NODE, h('2F C2 60 02 FC 00 00 00')) == abort(0x60C2, 2, 0x06090030)  # x 100 us: 2.5 ms
        m.download(NODE, '2F C2 60 01 04 00 00 00')
        assert axis.interpolation_period() == 0.001, 'one sub-index is not enough'
        m.download(NODE, '2F C2 60 02 FD 00 00 00')
        assert axis.interpolation_period() == 0.004
        m.download(NODE, '2F C2 60 02 FC 00 00 00')  # 4 x 100 us ...
        m.download(NODE, '2F C2 60 01 14 00 00 00')  # ... = 20 x 100 us = 2 ms: whole ms
        assert axis.interpolation_period() == 0.002
        assert m.sdo(NODE, h('2B C0 60 00 FF FF 00 00')) == abort(0x60C0, 0, 0x06090030), '-1 is reserved'
        assert m.sdo(NODE, h('2B C0 60 00 FD FF 00 00')) == abort(0x60C0, 0, 0x06090032), 'below -2'
        assert m.sdo(NODE, h('2F C4 60 05 02 00 00 00')) == abort(0x60C4, 5, 0x06090030), 'linear: size 1 only'


def test_pdo_rules() -> None:
    with akd_bus(NODE) as (_bench, sniffer, m, _sims):
        assert m.sdo(NODE, h('40 00 14 03 00 00 00 00')) == abort(0x1400, 3, 0x06090011), 'RPDO: sub0..2 only'
        assert m.sdo(NODE, h('2F 00 18 02 FE 00 00 00')) == abort(0x1800, 2, 0x06090030), 'no type 254'
        assert m.sdo(NODE, h('2F 00 14 02 F1 00 00 00')) == abort(0x1400, 2, 0x06090030)
        m.download(NODE, '2F 00 1A 00 00 00 00 00')  # pre-operational: remapping a valid PDO is accepted
        m.download(NODE, '23 00 1A 01 10 00 41 60')
        m.download(NODE, '23 00 1A 02 20 00 02 10')  # + 0x1002 manufacturer status
        m.download(NODE, '2F 00 1A 00 02 00 00 00')
        assert m.sdo(NODE, h('23 00 1A 01 08 00 41 60')) == abort(0x1A00, 1, 0x08000022), 'sub0 first'
        mark = m.send(0x000, bytes([0x01, NODE]))
        m.expect(0x181, '40 02 08 00 00 20', after=mark)  # statusword + 0x1002: in position, HW enable
        assert m.sdo(NODE, h('2F 00 1A 00 00 00 00 00')) == abort(0x1A00, 0, 0x08000022), 'map before NMT start'
        assert m.sdo(NODE, h('23 00 18 01 85 01 00 00')) == abort(0x1800, 1, 0x06090030), 'id of a valid PDO'


def test_quick_stop_stays_in_quick_stop_active() -> None:
    with akd_bus(NODE) as (_bench, sniffer, m, _sims):
        m.download(NODE, '2F 60 60 00 03 00 00 00')  # profile velocity
        wait_upload(m, 0x6061, 0, '4F 61 60 00 03 00 00 00')
        enable(m, sniffer)
        m.download(NODE, '23 FF 60 00 00 00 10 00')  # 2^20 counts/s
        time.sleep(0.1)
        mark = sniffer.mark
        m.send(0x201, h('0B 00'))  # quick stop
        m.expect_later(0x181, '17 06', after=mark)  # Quick Stop Active at standstill (bit 10)
        assert m.read_u32(NODE, 0x1002) & 1 << 19, '0x1002: emergency stop active'
        assert m.upload(NODE, 0x60FF) == h('43 FF 60 00 00 00 00 00'), 'the set-point was cancelled'
        mark = sniffer.mark
        m.send(0x201, h('0F 00'))  # transition 16: back to Operation Enabled
        m.expect(0x181, '37 12', after=mark)  # pv: bit 12 = speed 0
        time.sleep(0.05)
        assert m.read_i32(NODE, 0x606C) == 0, 'no motion without a new set-point'


def test_sync_supervision_f125() -> None:
    with akd_bus(NODE) as (_bench, sniffer, m, _sims):
        m.download(NODE, '23 E8 36 00 01 00 00 00')  # FBUS.PARAM04 = 1
        m.download(NODE, '2F C2 60 01 0A 00 00 00')  # 10 ...
        m.download(NODE, '2F C2 60 02 FD 00 00 00')  # ... ms
        m.download(NODE, '2F 60 60 00 07 00 00 00')
        mark = sniffer.mark
        enable(m, sniffer)
        for _ in range(5):
            last = m.sync()
            time.sleep(0.01)
        emcy = m.expect(0x081, '80 87 21 01 00 00 00 00', after=mark, timeout=1.0)  # F125
        assert emcy.index > last.index and emcy.stamp - last.stamp > 0.03, 'after three missing SYNCs'
        m.expect_later(0x181, '08 02', after=mark)


def test_save_and_load_signatures() -> None:
    with akd_bus(NODE) as (_bench, _sniffer, m, _sims):
        assert m.sdo(NODE, h('23 10 10 01 00 00 00 00')) == abort(0x1010, 1, 0x08000020)
        m.download(NODE, '23 81 60 00 00 00 01 00')  # profile velocity 65536
        m.download(NODE, '23 10 10 01 73 61 76 65')  # "save"
        assert m.upload(NODE, 0x1010, 1) == h('43 10 10 01 01 00 00 00')
        m.download(NODE, '23 81 60 00 0A 00 00 00')
        m.download(NODE, '23 11 10 01 6C 6F 61 64')  # "load": back to the saved value
        assert m.upload(NODE, 0x6081) == h('43 81 60 00 00 00 01 00')


def test_change_masks_and_rpdo_every_nth_sync() -> None:
    with akd_bus(NODE) as (_bench, sniffer, m, _sims):
        m.download(NODE, '23 14 20 01 00 00 00 00')  # 0x2014:1 = 0: no statusword bit triggers TPDO1
        m.download(NODE, '2F 00 14 02 02 00 00 00')  # RPDO1 (controlword) taken at every 2nd SYNC
        mark = m.send(0x000, bytes([0x01, NODE]))
        m.expect(0x181, '40 02', after=mark)  # sent on entering OPERATIONAL regardless
        m.send(0x201, h('06 00'))
        first = m.sync()
        assert m.upload(NODE, 0x6041)[4:6] == h('40 02'), 'not yet: the first SYNC is skipped'
        m.sync()
        assert m.upload(NODE, 0x6041)[4:6] == h('31 02'), 'applied at the second SYNC'
        assert not sniffer.frames(0x181, after=first.index), 'masked: no TPDO1'
        m.download(NODE, '23 14 20 01 FF 00 00 00')  # low byte of the statusword triggers again
        m.send(0x201, h('07 00'))
        mark = m.sync().index
        m.sync()
        m.expect(0x181, '33 02', after=mark)
