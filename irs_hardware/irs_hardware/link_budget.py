"""The link's budget at 1 kHz: bytes per step against the link's rate (no I/O).

A UART byte is 10 bits (8N1); the busier direction (board -> host) decides. Per 1 ms step:

- StandardFirmata: three analog messages of 3 bytes (10-bit ADC, 14-bit field) = 9 bytes in,
  an analog (servo) message of 3 bytes out; no sequence number, no CRC, no watchdog, and the
  firmware's sampling interval is at least 1 ms (MINIMUM_SAMPLING_INTERVAL 1; default 19 ms;
  10 ms in ConfigurableFirmata) -- at 57600 baud 9 bytes per ms are 156 % of the link.
- IRSL (:mod:`.protocol`): a 24-byte SAMPLE in, a 12-byte COMMAND out; the torque car's board
  adds 4 wheel counts (16 bytes) in and 4 motor commands (8 bytes) out: 40 in, 20 out.
"""
FIRMATA_IN, FIRMATA_OUT = 9, 3
IRSL_IN, IRSL_OUT = 24, 12
IRSL_WHEELS_IN, IRSL_WHEELS_OUT = 40, 20
RATE = 1000.0          # [steps/s]


def budget_rows(rate: float = RATE) -> list:
    """``[{name, bytes_in, bytes_out, baud, load, frame_time_ms}]``; load = the busier
    direction's bits per second over the baud rate.
    """
    rows = []
    for name, b_in, b_out, baud in (('StandardFirmata', FIRMATA_IN, FIRMATA_OUT, 57600),
                                    ('StandardFirmata', FIRMATA_IN, FIRMATA_OUT, 115200),
                                    ('IRSL', IRSL_IN, IRSL_OUT, 115200),
                                    ('IRSL', IRSL_IN, IRSL_OUT, 1000000),
                                    ('IRSL torque car', IRSL_WHEELS_IN, IRSL_WHEELS_OUT, 115200),
                                    ('IRSL torque car', IRSL_WHEELS_IN, IRSL_WHEELS_OUT,
                                     1000000)):
        rows.append({'name': f'{name} @ {baud}', 'bytes_in': b_in, 'bytes_out': b_out,
                     'baud': baud, 'load': max(b_in, b_out) * 10 * rate / baud,
                     'frame_time_ms': b_in * 10 / baud * 1e3})
    return rows
