// IRSL v1 board firmware (irs_hardware/protocol.py is the specification; docs/hardware.md the
// wiring). Not compiled in this repository (no Arduino toolchain here): the board emulator
// (irs_hardware/emulator/board_core.py) implements the same behaviour and is what the tests run.
//
// Frames: A5 5A | version | type | length | payload | crc16 (CRC-16/CCITT-FALSE, LE).
// HELLO(mode, watchdog_ms, interval_us, safe pulse ticks) -> INFO; COMMAND(seq, pulse ticks
// 0.5 us, flags); SAMPLE(tick, ack, adc[3], belt, status) every interval (free-running) or per
// COMMAND (triggered). Watchdog, counted in samples and armed by the first COMMAND after HELLO:
// watchdog_ms / interval samples in a row without a good COMMAND -> the safe pulse, enable
// low, latched until the next HELLO.
// The torque car (build with IRS_WHEELS on an ATmega2560): INFO declares 4 wheel counters;
// COMMAND adds 4 x i16 motor commands [per-mille], SAMPLE 4 x i32 wheel counts (LS7366R
// counters on SPI); the motors' PWM set values (10-90 % = -1000..+1000) are 0 (50 %) in the
// safe state, and their drivers' enable follows the enable relay.
#include <SPI.h>

const uint8_t VERSION = 1, HELLO = 0x01, COMMAND = 0x02, INFO = 0x81, SAMPLE = 0x82;
#ifdef IRS_WHEELS
const uint8_t PIN_CS = 53, PIN_ENABLE = 30, PIN_ENC_A = 2, PIN_ENC_B = 3, PIN_SERVO = 11;
const uint8_t WHEELS = 4, PIN_WHEEL_CS[4] = {22, 23, 24, 25};
volatile uint16_t *const MOTOR_OCR[4] = {&OCR4A, &OCR4B, &OCR4C, &OCR5A};
const uint16_t MOTOR_TOP = 7999;               // 2 kHz at 16 MHz, prescaler 1
#else
const uint8_t PIN_CS = 10, PIN_ENABLE = 7, PIN_ENC_A = 2, PIN_ENC_B = 3, PIN_SERVO = 9;
const uint8_t WHEELS = 0;
#endif
uint16_t safeTicks = 3000;                    // the HELLO's safe pulse (1500 us until then)
volatile int32_t beltCount = 0;
uint32_t tick = 0, intervalUs = 1000, nextSampleUs = 0;
uint16_t watchdogTicks = 25, sinceCommand = 0;
uint16_t ack = 0;
bool started = false, triggered = false, tripped = false, armed = false, badHostFrame = false;
uint8_t rx[80];
uint8_t rxLen = 0;

uint16_t crc16(const uint8_t *d, uint8_t n) {
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < n; i++) {
    crc ^= (uint16_t)d[i] << 8;
    for (uint8_t b = 0; b < 8; b++) crc = (crc & 0x8000) ? (crc << 1) ^ 0x1021 : crc << 1;
  }
  return crc;
}

void sendFrame(uint8_t type, const uint8_t *payload, uint8_t n) {
  uint8_t buf[80];
  buf[0] = 0xA5; buf[1] = 0x5A; buf[2] = VERSION; buf[3] = type; buf[4] = n;
  memcpy(buf + 5, payload, n);
  uint16_t c = crc16(buf + 2, n + 3);
  buf[5 + n] = c & 0xFF; buf[6 + n] = c >> 8;
  Serial.write(buf, n + 7);
}

void encoderIsr() {                            // x4 quadrature on INT0/INT1
  static uint8_t last = 0;
  uint8_t now = (digitalRead(PIN_ENC_A) << 1) | digitalRead(PIN_ENC_B);
  static const int8_t table[16] = {0, -1, 1, 0, 1, 0, 0, -1, -1, 0, 0, 1, 0, 1, -1, 0};
  beltCount += table[(last << 2) | now];
  last = now;
}

uint16_t readAdc(uint8_t ch) {                 // ADS8688 manual channel select, 16-bit result
  SPI.beginTransaction(SPISettings(10000000, MSBFIRST, SPI_MODE1));
  digitalWrite(PIN_CS, LOW);
  SPI.transfer16(0xC000 | (ch << 10));
  uint16_t v = SPI.transfer16(0);
  digitalWrite(PIN_CS, HIGH);
  SPI.endTransaction();
  return v;
}

void setPulse(uint16_t ticks) { OCR1A = ticks; }   // Timer1 fast PWM, TOP = 40000 (20 ms)

void setMotors(const int16_t *permille) {       // 50 % duty = 0 A; +-1000 = 90 % / 10 %
#ifdef IRS_WHEELS
  for (uint8_t i = 0; i < WHEELS; i++) {
    int32_t c = constrain(permille[i], -1000, 1000);
    *MOTOR_OCR[i] = (MOTOR_TOP + 1) / 2 + c * (int32_t)(MOTOR_TOP + 1) * 4 / 10000;
  }
#endif
}

void safeState() {
  static const int16_t zero[4] = {0, 0, 0, 0};
  setPulse(safeTicks); setMotors(zero); digitalWrite(PIN_ENABLE, LOW);
}

int32_t readWheel(uint8_t i) {                  // LS7366R: RD_CNTR, 4 bytes MSB first
#ifdef IRS_WHEELS
  SPI.beginTransaction(SPISettings(8000000, MSBFIRST, SPI_MODE0));
  digitalWrite(PIN_WHEEL_CS[i], LOW);
  SPI.transfer(0x60);
  uint32_t v = 0;
  for (uint8_t b = 0; b < 4; b++) v = (v << 8) | SPI.transfer(0);
  digitalWrite(PIN_WHEEL_CS[i], HIGH);
  SPI.endTransaction();
  return (int32_t)v;
#else
  return 0;
#endif
}

void sendSample() {
  uint8_t p[33];
  int32_t belt; noInterrupts(); belt = beltCount; interrupts();
  uint16_t adc[3] = {readAdc(0), readAdc(1), readAdc(2)};
  memcpy(p, &tick, 4); memcpy(p + 4, &ack, 2); memcpy(p + 6, adc, 6); memcpy(p + 12, &belt, 4);
  p[16] = (tripped ? 1 : 0) | (badHostFrame ? 2 : 0);
  badHostFrame = false;
  for (uint8_t i = 0; i < WHEELS; i++) { int32_t w = readWheel(i); memcpy(p + 17 + 4 * i, &w, 4); }
  sendFrame(SAMPLE, p, 17 + 4 * WHEELS);
}

void handle(uint8_t type, const uint8_t *p, uint8_t n) {
  if (type == HELLO && n == 7) {
    triggered = p[0] == 1;
    intervalUs = p[3] | (p[4] << 8);
    watchdogTicks = max(1UL, 1000UL * (p[1] | (p[2] << 8)) / intervalUs);
    safeTicks = p[5] | (p[6] << 8);
    started = true; tripped = false; armed = false; sinceCommand = 0; nextSampleUs = micros();
    safeState();
    uint8_t info[11] = {1, 0, 16, 3, (uint8_t)(intervalUs & 0xFF), (uint8_t)(intervalUs >> 8),
                        244, 1, p[1], p[2], WHEELS};
    sendFrame(INFO, info, 11);
    if (triggered) sendSample();
  } else if (type == COMMAND && (n == 5 || n == 13) && started) {
    ack = p[0] | (p[1] << 8);
    armed = true; sinceCommand = 0;
    if (!tripped) {
      bool enable = p[4] & 1;
      int16_t motors[4] = {0, 0, 0, 0};
      if (n == 13 && enable) memcpy(motors, p + 5, 8);
      setPulse(p[2] | (p[3] << 8));
      setMotors(motors);
      digitalWrite(PIN_ENABLE, enable ? HIGH : LOW);
    }
    if (triggered) { tick++; sendSample(); }
  }
}

void pollSerial() {
  while (Serial.available()) {
    if (rxLen >= sizeof(rx)) rxLen = 0;
    rx[rxLen++] = Serial.read();
    if (rxLen >= 1 && rx[0] != 0xA5) { rxLen = 0; continue; }
    if (rxLen >= 2 && rx[1] != 0x5A) { rxLen = 0; continue; }
    if (rxLen < 5) continue;
    uint8_t n = rx[4];
    if (n > 64) { badHostFrame = true; rxLen = 0; continue; }
    if (rxLen < n + 7) continue;
    uint16_t c = rx[5 + n] | (rx[6 + n] << 8);
    if (rx[2] == VERSION && c == crc16(rx + 2, n + 3)) handle(rx[3], rx + 5, n);
    else badHostFrame = true;
    rxLen = 0;
  }
}

void setup() {
  Serial.begin(1000000);
  pinMode(PIN_CS, OUTPUT); digitalWrite(PIN_CS, HIGH);
  pinMode(PIN_ENABLE, OUTPUT);
  pinMode(PIN_SERVO, OUTPUT);
  TCCR1A = _BV(COM1A1) | _BV(WGM11); TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS11);
  ICR1 = 40000;                                 // 20 ms frame at 0.5 us ticks
#ifdef IRS_WHEELS
  const uint8_t motorPins[4] = {6, 7, 8, 46};     // OC4A, OC4B, OC4C, OC5A
  for (uint8_t i = 0; i < 4; i++) pinMode(motorPins[i], OUTPUT);
  TCCR4A = _BV(COM4A1) | _BV(COM4B1) | _BV(COM4C1) | _BV(WGM41);   // fast PWM, TOP = ICR
  TCCR4B = _BV(WGM43) | _BV(WGM42) | _BV(CS40); ICR4 = MOTOR_TOP;
  TCCR5A = _BV(COM5A1) | _BV(WGM51);
  TCCR5B = _BV(WGM53) | _BV(WGM52) | _BV(CS50); ICR5 = MOTOR_TOP;
#endif
  safeState();
  SPI.begin();
#ifdef IRS_WHEELS
  for (uint8_t i = 0; i < WHEELS; i++) {        // LS7366R: x4 quadrature, 4-byte counter, 0
    pinMode(PIN_WHEEL_CS[i], OUTPUT);
    const uint8_t setup[3][2] = {{0x88, 0x03}, {0x90, 0x00}, {0x20, 0}};
    for (uint8_t k = 0; k < 3; k++) {
      digitalWrite(PIN_WHEEL_CS[i], LOW);
      SPI.transfer(setup[k][0]);
      if (k < 2) SPI.transfer(setup[k][1]);
      digitalWrite(PIN_WHEEL_CS[i], HIGH);
    }
  }
#endif
  attachInterrupt(digitalPinToInterrupt(PIN_ENC_A), encoderIsr, CHANGE);
  attachInterrupt(digitalPinToInterrupt(PIN_ENC_B), encoderIsr, CHANGE);
}

void loop() {
  pollSerial();
  uint32_t now = micros();
  if (started && !triggered && (int32_t)(now - nextSampleUs) >= 0) {
    nextSampleUs += intervalUs;
    if (armed && !tripped && ++sinceCommand >= watchdogTicks) {
      tripped = true;
      safeState();
    }
    tick++;
    sendSample();
  }
}
