"""IRSL framing: round trips, CRC check value, resynchronisation after garbage and garbled
frames, every bad frame counted (hypothesis: any corruption of a byte is never a good frame).
"""
from hypothesis import given, settings, strategies as st

from irs_hardware import protocol as P
from irs_hardware.link_budget import budget_rows

SAMPLE = P.Sample(tick=123456, ack=77, adc=(1, 40000, 65535), belt=-42, status=P.OVERRUN)


def test_crc_check_value():
    assert P.crc16(b'123456789') == 0x29B1          # CRC-16/CCITT-FALSE


def test_round_trip_of_every_message():
    msgs = [P.Hello(1, 25, 1000), P.Info(1, 16, 3, 1000, 500, 25, 0),
            P.Command(65535, 3024, P.DRIVE_ENABLE), P.Command(3, 3000, 0, (1, -2, 3, -4)),
            SAMPLE, P.Sample(1, 2, (3, 4, 5), 6, 0, (7, 8, -9, 10))]
    parser = P.FrameParser()
    assert parser.feed(b''.join(P.encode(m) for m in msgs)) == msgs
    assert parser.bad == 0


def test_frame_sizes_of_the_link_budget():
    assert len(P.encode(SAMPLE)) == 24
    assert len(P.encode(P.Command(1, 3000, 1))) == 12
    assert len(P.encode(P.Sample(1, 2, (3, 4, 5), 6, 0, (7, 8, -9, 10)))) == 40
    assert len(P.encode(P.Command(1, 3000, 1, (1000, -1000, 0, 5)))) == 20


def test_garbage_between_frames_is_skipped_and_a_garbled_frame_counted():
    good = P.encode(SAMPLE)
    bad = bytearray(good)
    bad[10] ^= 0x01
    parser = P.FrameParser()
    out = parser.feed(b'\x00\xa5\xff' + good + bytes(bad) + good[:9])
    out += parser.feed(good[9:])
    assert out == [SAMPLE, SAMPLE]
    assert parser.bad == 1
    assert parser.skipped >= 3


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 23), st.integers(1, 255))
def test_any_single_byte_corruption_is_refused(pos, flip):
    data = bytearray(P.encode(SAMPLE))
    data[pos] ^= flip
    parser = P.FrameParser()
    out = parser.feed(bytes(data) + P.encode(SAMPLE))
    assert out[-1] == SAMPLE                      # the next good frame always comes through
    assert SAMPLE not in out[:-1] and len(out) == 1


def test_link_budget_rows_say_firmata_does_not_fit_and_irsl_does():
    rows = {r['name']: r for r in budget_rows()}
    assert rows['StandardFirmata @ 57600']['load'] > 1.0
    assert rows['IRSL @ 115200']['load'] > 1.0
    assert rows['IRSL @ 1000000']['load'] < 0.3
    assert rows['IRSL torque car @ 115200']['load'] > 1.0
    assert rows['IRSL torque car @ 1000000']['load'] == 0.4      # 40 B x 10 bit per ms
