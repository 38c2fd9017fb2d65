/* Unit tests of the firmware's portable core, compiled with the host's C compiler:
 *     cc -std=c99 -Icore tests/test_core.c core/iwp_core.c core/iwp_frame.c -lm && ./a.out
 * (tests/test_firmware.py does this). Prints one line per failure and "N passed, M failed". */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "iwp_core.h"
#include "iwp_frame.h"

static int passed, failed;
#define CHECK(cond) do { if (cond) passed++; else { failed++; printf("FAIL %s:%d: %s\n", __FILE__, __LINE__, #cond); } } while (0)

static iwp_core_t core;
static uint8_t out[4096];
static uint16_t n_out;

/* ---- helpers: a frame from a payload, the device's answers decoded */
static void put32(uint8_t *b, uint32_t v) { for (int i = 0; i < 4; i++) b[i] = (uint8_t)(v >> (8 * i)); }
static void putf(uint8_t *b, float f) { uint32_t v; memcpy(&v, &f, 4); put32(b, v); }
static uint32_t get32(const uint8_t *b) { return b[0] | b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24; }
static float getf(const uint8_t *b) { uint32_t v = get32(b); float f; memcpy(&f, &v, 4); return f; }

static void send(const uint8_t *payload, uint8_t n)
{
    uint8_t body[80], frame[90];
    memcpy(body, payload, n);
    uint16_t crc = iwp_crc16(payload, n);
    body[n] = (uint8_t)(crc >> 8);
    body[n + 1] = (uint8_t)crc;
    frame[0] = 0;
    uint16_t m = iwp_cobs_encode(body, (uint16_t)(n + 2), frame + 1);
    frame[m + 1] = 0;
    iwp_core_rx(&core, frame, (uint16_t)(m + 2));
}

/* a request without fields but its req (numbered here from 1) */
static uint16_t req;
static void send0(uint8_t type)
{
    req++;
    uint8_t b[3] = {type, (uint8_t)req, (uint8_t)(req >> 8)};
    send(b, sizeof b);
}

/* the last message of a type among the device's answers since the last call (payload into msg) */
static int last(uint8_t type, uint8_t *msg)
{
    n_out = iwp_core_tx_take(&core, out, sizeof out);
    int found = 0;
    uint16_t i = 0;
    while (i < n_out) {
        if (out[i] == 0) { i++; continue; }
        uint16_t j = i;
        while (j < n_out && out[j]) j++;
        uint8_t buf[90];
        memcpy(buf, out + i, j - i);
        int16_t m = iwp_cobs_decode_inplace(buf, (uint16_t)(j - i));
        if (m >= 3 && iwp_crc16(buf, (uint16_t)(m - 2)) == (uint16_t)(buf[m - 2] << 8 | buf[m - 1]) && buf[0] == type) {
            memcpy(msg, buf, (size_t)(m - 2));
            found = 1;
        }
        i = j;
    }
    return found;
}

static void set_param(uint8_t id, float v)
{
    uint8_t b[IWP_MSG_SET_PARAM_SIZE] = {IWP_MSG_SET_PARAM};
    req++;
    b[IWP_OFF_SET_PARAM_REQ] = (uint8_t)req;
    b[IWP_OFF_SET_PARAM_REQ + 1] = (uint8_t)(req >> 8);
    b[IWP_OFF_SET_PARAM_PARAM] = id;
    putf(b + IWP_OFF_SET_PARAM_VALUE, v);
    send(b, sizeof b);
}

static void command(uint32_t seq, uint32_t tick, float u)
{
    uint8_t b[IWP_MSG_COMMAND_SIZE] = {IWP_MSG_COMMAND};
    put32(b + IWP_OFF_COMMAND_SEQ, seq);
    put32(b + IWP_OFF_COMMAND_TICK, tick);
    putf(b + IWP_OFF_COMMAND_U, u);
    send(b, sizeof b);
}

static uint32_t now_us;
static float tick(int32_t c1, int32_t c2)
{
    now_us += (uint32_t)iwp_core_period_us(&core);
    return iwp_core_tick(&core, c1, c2, NAN, now_us);
}

static void reset(void)
{
    iwp_core_init(&core, 0, IWP_CAP_HOPF | IWP_CAP_STATE_FEEDBACK | IWP_CAP_HOST_CLOCK, 100);
    now_us = 0;
    iwp_core_tx_take(&core, out, sizeof out);
}

/* ---- the tests */
static void test_crc_and_cobs(void)
{
    CHECK(iwp_crc16((const uint8_t *)"123456789", 9) == 0x29B1); /* CRC-16/CCITT-FALSE check value */
    uint8_t src[300], enc[310];
    for (int i = 0; i < 300; i++) src[i] = (uint8_t)(i % 7 == 0 ? 0 : i);
    uint16_t m = iwp_cobs_encode(src, 300, enc);
    int zero = 0;
    for (int i = 0; i < m; i++) zero |= enc[i] == 0;
    CHECK(!zero);
    CHECK(iwp_cobs_decode_inplace(enc, m) == 300 && memcmp(enc, src, 300) == 0);
    uint8_t bad[3] = {5, 1, 2}; /* a block longer than the data */
    CHECK(iwp_cobs_decode_inplace(bad, 3) == -1);
}

static void test_hello_and_params(void)
{
    uint8_t m[80];
    reset();
    uint8_t hello[IWP_MSG_HELLO_SIZE] = {IWP_MSG_HELLO, 0x34, 0x12};
    send(hello, sizeof hello);
    CHECK(last(IWP_MSG_IDENT, m));
    CHECK(m[IWP_OFF_IDENT_NONCE] == 0x34 && m[IWP_OFF_IDENT_PROTOCOL] == IWP_PROTOCOL_VERSION);
    CHECK(get32(m + IWP_OFF_IDENT_DICT_HASH) == IWP_DICT_HASH);
    set_param(IWP_P_WATCHDOG_MS, 50.0f);
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_OK && getf(m + IWP_OFF_ACK_VALUE) == 50.0f);
    set_param(IWP_P_WATCHDOG_MS, 1e9f); /* out of range: refused, value kept */
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_OUT_OF_RANGE && getf(m + IWP_OFF_ACK_VALUE) == 50.0f);
    set_param(IWP_P_V_MAX, NAN);
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_OUT_OF_RANGE);
    set_param(IWP_P_PERIOD_US, 5050.0f); /* not a multiple of base_us */
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_OUT_OF_RANGE);
    set_param(200, 1.0f);
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_BAD_PARAM);
}

static void test_feedforward_saturation_and_queue(void)
{
    uint8_t m[80];
    reset();
    send0(IWP_MSG_ARM);
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_OK);
    command(1, 2, 10.0f);  /* from tick 2 */
    command(2, 3, -10.0f); /* from tick 3 */
    command(3, 4, 90.0f);  /* from tick 4: 90 + 31 saturates at 100 */
    CHECK(tick(0, 0) == 0.0f); /* tick 1: nothing for it yet (late) */
    CHECK(last(IWP_MSG_TELEMETRY, m) && (get32(m + IWP_OFF_TELEMETRY_FLAGS) & IWP_FLAG_LATE));
    CHECK(tick(0, 0) == 41.0f);
    CHECK(tick(0, 0) == -41.0f);
    CHECK(tick(0, 0) == 100.0f);
    CHECK(last(IWP_MSG_TELEMETRY, m) && getf(m + IWP_OFF_TELEMETRY_U) == 90.0f && getf(m + IWP_OFF_TELEMETRY_V) == 100.0f
          && (m[IWP_OFF_TELEMETRY_FLAGS] & IWP_FLAG_SATURATED));
    command(3, 6, 0.0f); /* a repeated sequence number: refused */
    tick(0, 0);
    CHECK(last(IWP_MSG_TELEMETRY, m) && getf(m + IWP_OFF_TELEMETRY_V) == 100.0f && m[IWP_OFF_TELEMETRY_RX_ERRORS] == 1);
    command(4, 0, NAN); /* NaN is never applied */
    tick(0, 0);
    CHECK(last(IWP_MSG_TELEMETRY, m) && getf(m + IWP_OFF_TELEMETRY_V) == 100.0f && m[IWP_OFF_TELEMETRY_RX_ERRORS] == 2);
}

static void test_corrupt_frames_are_not_applied(void)
{
    uint8_t m[80];
    reset();
    send0(IWP_MSG_ARM);
    uint8_t b[IWP_MSG_COMMAND_SIZE] = {IWP_MSG_COMMAND}, body[20], frame[24];
    put32(b + IWP_OFF_COMMAND_SEQ, 1);
    put32(b + IWP_OFF_COMMAND_TICK, 0);
    putf(b + IWP_OFF_COMMAND_U, 50.0f);
    memcpy(body, b, sizeof b);
    uint16_t crc = iwp_crc16(b, sizeof b);
    body[sizeof b] = (uint8_t)(crc >> 8);
    body[sizeof b + 1] = (uint8_t)crc;
    frame[0] = 0;
    uint16_t n = iwp_cobs_encode(body, sizeof b + 2, frame + 1);
    frame[n + 1] = 0;
    int bad_applied = 0;
    uint32_t hb_seq = 0;
    for (uint16_t i = 1; i <= n; i++) { /* every single-bit error of every byte */
        for (int bit = 0; bit < 8; bit++) {
            uint8_t f[24], hb[IWP_MSG_HEARTBEAT_SIZE] = {IWP_MSG_HEARTBEAT};
            memcpy(f, frame, (size_t)n + 2);
            f[i] ^= (uint8_t)(1 << bit);
            iwp_core_rx(&core, f, (uint16_t)(n + 2));
            put32(hb + IWP_OFF_HEARTBEAT_SEQ, ++hb_seq); /* keeps the watchdog fed */
            send(hb, sizeof hb);
            if (tick(0, 0) != 0.0f) bad_applied++;
        }
    }
    CHECK(bad_applied == 0);
    iwp_core_rx(&core, frame, (uint16_t)(n + 2)); /* the good one */
    CHECK(tick(0, 0) == 81.0f);
    CHECK(last(IWP_MSG_TELEMETRY, m) && m[IWP_OFF_TELEMETRY_STATE] == IWP_STATE_ARMED);
}

static void test_watchdog_limits_estop(void)
{
    uint8_t m[80];
    reset(); /* watchdog 100 ms at 5 ms: the 21st tick without a command trips it */
    send0(IWP_MSG_ARM);
    command(1, 0, 20.0f);
    int k = 0;
    while (tick(0, 0) != 0.0f) {
        k++;
        last(IWP_MSG_TELEMETRY, m); /* drain, as the hardware layer does */
    }
    CHECK(k == 19); /* ticks 1..19 drive the motor; tick 20, 100 ms after the command, stops it */
    CHECK(last(IWP_MSG_TELEMETRY, m) && m[IWP_OFF_TELEMETRY_STATE] == IWP_STATE_FAULT
          && m[IWP_OFF_TELEMETRY_FAULT] == IWP_FAULT_WATCHDOG);
    send0(IWP_MSG_ARM); /* refused until CLEAR */
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_FAULT);
    send0(IWP_MSG_CLEAR);
    send0(IWP_MSG_ARM);
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_OK);
    command(2, 0, 10.0f);
    tick(0, 0);
    CHECK(tick(5000, 0) == 0.0f); /* |q1| = 15.7 rad > q1_max */
    CHECK(last(IWP_MSG_TELEMETRY, m) && m[IWP_OFF_TELEMETRY_FAULT] == IWP_FAULT_Q1_LIMIT);
    send0(IWP_MSG_ESTOP);
    send0(IWP_MSG_ESTOP); /* idempotent */
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_OK);
    tick(0, 0);
    /* an ESTOP in FAULT keeps the fault that stopped the motor (the one to report), the motor off */
    CHECK(last(IWP_MSG_TELEMETRY, m) && m[IWP_OFF_TELEMETRY_STATE] == IWP_STATE_FAULT &&
          m[IWP_OFF_TELEMETRY_FAULT] == IWP_FAULT_Q1_LIMIT && getf(m + IWP_OFF_TELEMETRY_V) == 0.0f);
}

static void test_acks_echo_req_and_a_repeated_arm_feeds_the_watchdog(void)
{
    uint8_t m[80];
    reset(); /* watchdog 100 ms at 5 ms */
    send0(IWP_MSG_ARM);
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_OK && m[IWP_OFF_ACK_MSG] == IWP_MSG_ARM
          && (m[IWP_OFF_ACK_REQ] | m[IWP_OFF_ACK_REQ + 1] << 8) == req);
    command(1, 0, 20.0f);
    for (int k = 0; k < 15; k++) { tick(0, 0); last(IWP_MSG_TELEMETRY, m); }
    send0(IWP_MSG_ARM); /* 75 ms on: the host repeats ARM (its ACK was lost): OK, and the watchdog is fed */
    CHECK(last(IWP_MSG_ACK, m) && m[IWP_OFF_ACK_CODE] == IWP_ACK_OK
          && (m[IWP_OFF_ACK_REQ] | m[IWP_OFF_ACK_REQ + 1] << 8) == req);
    int k = 0;
    while (tick(0, 0) != 0.0f) { k++; last(IWP_MSG_TELEMETRY, m); }
    CHECK(k == 19); /* 100 ms counted from the repeated ARM, not from the command */
}

static void test_hopf_law(void)
{
    uint8_t m[80], mode[IWP_MSG_MODE_SIZE] = {IWP_MSG_MODE};
    mode[IWP_OFF_MODE_MODE] = IWP_MODE_HOPF;
    reset();
    set_param(IWP_P_FILTER_TAU, 0.0f);
    send(mode, sizeof mode);
    send0(IWP_MSG_ARM);
    uint8_t hb[IWP_MSG_HEARTBEAT_SIZE] = {IWP_MSG_HEARTBEAT, 1};
    send(hb, sizeof hb);
    tick(0, 0);
    float v = tick(2, 0); /* q3 = 2 counts / 5 ms = 1.2566 rad/s: u = -10 q3 + 0.1 q3^3 = -12.368 */
    float q3 = 2.0f * 6.2831853f / 2000.0f / 0.005f, u = -10.0f * q3 + 0.1f * q3 * q3 * q3;
    CHECK(fabsf(v - (u - 31.0f)) < 1e-4f);
    CHECK(last(IWP_MSG_TELEMETRY, m) && fabsf(getf(m + IWP_OFF_TELEMETRY_U) - u) < 1e-4f);
}

int main(void)
{
    test_crc_and_cobs();
    test_hello_and_params();
    test_feedforward_saturation_and_queue();
    test_corrupt_frames_are_not_applied();
    test_watchdog_limits_estop();
    test_acks_echo_req_and_a_repeated_arm_feeds_the_watchdog();
    test_hopf_law();
    printf("%d passed, %d failed\n", passed, failed);
    return failed != 0;
}
