/* iwp_core.c: the portable core of iwp's rig firmware (see iwp_core.h and docs/protocol.md). */
#include "iwp_core.h"

#include <math.h>
#include <string.h>

#include "iwp_frame.h"

#ifdef __AVR__
#include <avr/pgmspace.h>
static const float PARAM_TABLE[IWP_N_PARAMS][3] PROGMEM = IWP_PARAM_TABLE;
#define TABLE(i, j) pgm_read_float(&PARAM_TABLE[i][j])
#else
static const float PARAM_TABLE[IWP_N_PARAMS][3] = IWP_PARAM_TABLE;
#define TABLE(i, j) (PARAM_TABLE[i][j])
#endif

#define TWO_PI 6.283185307179586f
#define PI_F 3.141592653589793f

/* ------------------------------------------------------------------ little-endian fields */
static void put_u16(uint8_t *b, uint16_t v) { b[0] = (uint8_t)v; b[1] = (uint8_t)(v >> 8); }
static void put_u32(uint8_t *b, uint32_t v)
{
    b[0] = (uint8_t)v; b[1] = (uint8_t)(v >> 8); b[2] = (uint8_t)(v >> 16); b[3] = (uint8_t)(v >> 24);
}
static void put_f32(uint8_t *b, float f) { uint32_t v; memcpy(&v, &f, 4); put_u32(b, v); }
static uint32_t get_u32(const uint8_t *b)
{
    return (uint32_t)b[0] | ((uint32_t)b[1] << 8) | ((uint32_t)b[2] << 16) | ((uint32_t)b[3] << 24);
}
static float get_f32(const uint8_t *b) { uint32_t v = get_u32(b); float f; memcpy(&f, &v, 4); return f; }

/* ------------------------------------------------------------------ sending */
static void tx_put(iwp_core_t *c, uint8_t byte)
{
    c->tx[c->tx_head] = byte;
    c->tx_head = (uint16_t)((c->tx_head + 1) & (IWP_TX_LEN - 1));
}

uint16_t iwp_core_tx_pending(const iwp_core_t *c) { return (uint16_t)((c->tx_head - c->tx_tail) & (IWP_TX_LEN - 1)); }

/* Room kept in the send buffer for answers (ACK, IDENT): telemetry that would eat into it is skipped (the host
 * sees the gap in its seq), answers never are. */
#define TX_RESERVE 40

static void send_frame(iwp_core_t *c, uint8_t *payload, uint8_t n, uint16_t reserve);
static void send(iwp_core_t *c, uint8_t *payload, uint8_t n) { send_frame(c, payload, n, 0); }

static void send_frame(iwp_core_t *c, uint8_t *payload, uint8_t n, uint16_t reserve)
{
    uint8_t body[IWP_MAX_PAYLOAD + 2];
    uint8_t stuffed[IWP_MAX_PAYLOAD + 4];
    uint16_t crc = iwp_crc16(payload, n);
    memcpy(body, payload, n);
    body[n] = (uint8_t)(crc >> 8);
    body[n + 1] = (uint8_t)crc;
    uint16_t m = iwp_cobs_encode(body, (uint16_t)(n + 2), stuffed);
    if ((uint16_t)(IWP_TX_LEN - 1 - iwp_core_tx_pending(c)) < m + 2 + reserve) return; /* no room: dropped */
    tx_put(c, 0);
    for (uint16_t i = 0; i < m; i++) tx_put(c, stuffed[i]);
    tx_put(c, 0);
}

uint16_t iwp_core_tx_take(iwp_core_t *c, uint8_t *buf, uint16_t max)
{
    uint16_t n = 0;
    while (n < max && c->tx_tail != c->tx_head) {
        buf[n++] = c->tx[c->tx_tail];
        c->tx_tail = (uint16_t)((c->tx_tail + 1) & (IWP_TX_LEN - 1));
    }
    return n;
}

/* Every request answered by ACK starts with its req (u16 at byte 1), echoed so that the host takes only the ACK
 * of the attempt it waits for. */
_Static_assert(IWP_OFF_GET_PARAM_REQ == 1 && IWP_OFF_SET_PARAM_REQ == 1 && IWP_OFF_ARM_REQ == 1 &&
               IWP_OFF_DISARM_REQ == 1 && IWP_OFF_ESTOP_REQ == 1 && IWP_OFF_CLEAR_REQ == 1 &&
               IWP_OFF_ZERO_REQ == 1 && IWP_OFF_MODE_REQ == 1 && IWP_OFF_FIXTURE_REQ == 1 &&
               IWP_OFF_STREAM_REQ == 1, "req is the first field of every acknowledged request");

/* The ACK of request m (its type and req) */
static void ack(iwp_core_t *c, const uint8_t *m, uint8_t code, uint8_t param, float value)
{
    uint8_t b[IWP_MSG_ACK_SIZE];
    b[0] = IWP_MSG_ACK;
    b[IWP_OFF_ACK_REQ] = m[1];
    b[IWP_OFF_ACK_REQ + 1] = m[2];
    b[IWP_OFF_ACK_MSG] = m[0];
    b[IWP_OFF_ACK_CODE] = code;
    b[IWP_OFF_ACK_PARAM] = param;
    put_f32(b + IWP_OFF_ACK_VALUE, value);
    send(c, b, sizeof b);
}

uint32_t iwp_core_params_hash(const iwp_core_t *c)
{
    uint32_t h = 2166136261UL;
    for (uint8_t i = 0; i < IWP_N_PARAMS; i++) {
        uint8_t b[4];
        put_f32(b, c->p[i]);
        for (uint8_t j = 0; j < 4; j++) h = (h ^ b[j]) * 16777619UL;
    }
    return h;
}

static void ident(iwp_core_t *c, uint16_t nonce)
{
    uint8_t b[IWP_MSG_IDENT_SIZE];
    b[0] = IWP_MSG_IDENT;
    put_u16(b + IWP_OFF_IDENT_NONCE, nonce);
    b[IWP_OFF_IDENT_PROTOCOL] = IWP_PROTOCOL_VERSION;
    b[IWP_OFF_IDENT_FW_MAJOR] = IWP_FW_MAJOR;
    b[IWP_OFF_IDENT_FW_MINOR] = IWP_FW_MINOR;
    b[IWP_OFF_IDENT_FW_PATCH] = IWP_FW_PATCH;
    b[IWP_OFF_IDENT_BOARD] = c->board;
    put_u16(b + IWP_OFF_IDENT_CAPS, c->caps);
    put_u32(b + IWP_OFF_IDENT_DICT_HASH, IWP_DICT_HASH);
    put_u32(b + IWP_OFF_IDENT_PARAMS_HASH, iwp_core_params_hash(c));
    put_u32(b + IWP_OFF_IDENT_BASE_US, c->base_us);
    put_u32(b + IWP_OFF_IDENT_TICK, c->tick);
    send(c, b, sizeof b);
}

static void telemetry(iwp_core_t *c)
{
    uint8_t b[IWP_MSG_TELEMETRY_SIZE];
    b[0] = IWP_MSG_TELEMETRY;
    put_u32(b + IWP_OFF_TELEMETRY_SEQ, c->tick);
    put_u32(b + IWP_OFF_TELEMETRY_T_US, c->t_us);
    put_u32(b + IWP_OFF_TELEMETRY_COUNT1, (uint32_t)c->c1);
    put_u32(b + IWP_OFF_TELEMETRY_COUNT2, (uint32_t)c->c2);
    put_f32(b + IWP_OFF_TELEMETRY_Q4, c->q4);
    put_f32(b + IWP_OFF_TELEMETRY_U, c->u);
    put_f32(b + IWP_OFF_TELEMETRY_V, c->v);
    put_f32(b + IWP_OFF_TELEMETRY_CURRENT, c->current);
    b[IWP_OFF_TELEMETRY_STATE] = c->state;
    b[IWP_OFF_TELEMETRY_FAULT] = c->fault;
    put_u16(b + IWP_OFF_TELEMETRY_FLAGS, c->flags);
    put_u16(b + IWP_OFF_TELEMETRY_OVERRUNS, c->overruns);
    put_u16(b + IWP_OFF_TELEMETRY_LATE, c->late);
    put_u16(b + IWP_OFF_TELEMETRY_RX_ERRORS, c->rx_errors);
    put_u16(b + IWP_OFF_TELEMETRY_DROPPED, c->dropped);
    send_frame(c, b, sizeof b, TX_RESERVE);
}

/* ------------------------------------------------------------------ parameters */
static void derive(iwp_core_t *c)
{
    c->step1 = TWO_PI / c->p[IWP_P_COUNTS1];
    c->step2 = TWO_PI / c->p[IWP_P_COUNTS2];
    c->dt = c->p[IWP_P_PERIOD_US] * 1e-6f;
    c->w1 = c->step1 / c->dt;
    c->w2 = c->step2 / c->dt;
    float tau = c->p[IWP_P_FILTER_TAU];
    c->a3 = tau > 0.0f ? expf(-c->dt / tau) : 0.0f;
    c->q4_stall = 0.1f * c->p[IWP_P_Q4_MAX];
    c->period_us = (uint32_t)c->p[IWP_P_PERIOD_US];
    c->watchdog_us = (uint32_t)(c->p[IWP_P_WATCHDOG_MS] * 1000.0f);
    c->sat_max_us = (uint32_t)(c->p[IWP_P_SAT_MS_MAX] * 1000.0f);
}

static uint8_t set_param(iwp_core_t *c, uint8_t id, float value)
{
    if (id >= IWP_N_PARAMS) return IWP_ACK_BAD_PARAM;
    if (!(value >= TABLE(id, 1) && value <= TABLE(id, 2))) return IWP_ACK_OUT_OF_RANGE; /* NaN too */
    if (id == IWP_P_PERIOD_US) {
        uint32_t us = (uint32_t)value;
        if ((float)us != value || us % c->base_us != 0) return IWP_ACK_OUT_OF_RANGE;
    }
    if (id == IWP_P_HOST_CLOCK && value != 0.0f && !(c->caps & IWP_CAP_HOST_CLOCK)) return IWP_ACK_BAD_MODE;
    c->p[id] = value;
    derive(c);
    return IWP_ACK_OK;
}

void iwp_core_init(iwp_core_t *c, uint8_t board, uint16_t caps, uint32_t base_us)
{
    memset(c, 0, sizeof *c);
    c->board = board;
    c->caps = caps;
    c->base_us = base_us ? base_us : 1;
    for (uint8_t i = 0; i < IWP_N_PARAMS; i++) c->p[i] = TABLE(i, 0);
    c->state = IWP_STATE_DISARMED;
    c->fault = IWP_FAULT_NONE;
    c->mode = IWP_MODE_HOST;
    c->stream_every = 1;
    c->current = NAN;
    derive(c);
}

uint32_t iwp_core_period_us(const iwp_core_t *c) { return c->period_us; }

float iwp_core_param(const iwp_core_t *c, uint8_t id) { return id < IWP_N_PARAMS ? c->p[id] : 0.0f; }

int iwp_core_fixture(iwp_core_t *c, uint8_t *action, float *q1)
{
    if (!c->fixture_pending) return 0;
    c->fixture_pending = 0;
    *action = c->fixture_action;
    *q1 = c->fixture_q1;
    return 1;
}

void iwp_core_status(const iwp_core_t *c, uint32_t *tick, uint8_t *state, uint8_t *fault, float *v)
{
    *tick = c->tick;
    *state = c->state;
    *fault = c->fault;
    *v = c->v;
}

uint32_t iwp_core_size(void) { return (uint32_t)sizeof(iwp_core_t); }

/* ------------------------------------------------------------------ state machine */
static void motor_off(iwp_core_t *c)
{
    c->u = 0.0f;
    c->v = 0.0f;
    c->n_queue = 0;
    c->sat_us = 0;
}

static void trip(iwp_core_t *c, uint8_t fault)
{
    c->state = (fault == IWP_FAULT_ESTOP) ? IWP_STATE_ESTOP : IWP_STATE_FAULT;
    c->fault = fault;
    motor_off(c);
}

static uint8_t outside_limits(const iwp_core_t *c)
{
    if (fabsf(c->q1) > c->p[IWP_P_Q1_MAX]) return IWP_FAULT_Q1_LIMIT;
    if (fabsf(c->q4) > c->p[IWP_P_Q4_MAX]) return IWP_FAULT_Q4_LIMIT;
    return IWP_FAULT_NONE;
}

static void enqueue(iwp_core_t *c, uint32_t tick, float u)
{
    if (tick == 0 || tick <= c->tick) tick = c->tick + 1;
    /* a command for an earlier tick than those queued replaces them (the host changed its plan) */
    while (c->n_queue && c->queue[c->n_queue - 1].tick >= tick) c->n_queue--;
    if (c->n_queue == IWP_QUEUE_LEN) {
        c->flags |= IWP_FLAG_QUEUE_FULL;
        c->dropped++; /* counted, wrapping: TELEMETRY dropped */
        return;
    }
    c->queue[c->n_queue].tick = tick;
    c->queue[c->n_queue].u = u;
    c->n_queue++;
}

static void dispatch(iwp_core_t *c, uint8_t *m, uint8_t n)
{
    uint8_t type = m[0];
    switch (type) {
    case IWP_MSG_HELLO:
        if (n != IWP_MSG_HELLO_SIZE) break;
        c->cmd_seq = 0; /* a new session: the host's sequence numbers start again */
        c->hb_seq = 0;
        ident(c, (uint16_t)(m[IWP_OFF_HELLO_NONCE] | (m[IWP_OFF_HELLO_NONCE + 1] << 8)));
        return;
    case IWP_MSG_GET_PARAM: {
        if (n != IWP_MSG_GET_PARAM_SIZE) break;
        uint8_t id = m[IWP_OFF_GET_PARAM_PARAM];
        if (id >= IWP_N_PARAMS) ack(c, m, IWP_ACK_BAD_PARAM, id, 0.0f);
        else ack(c, m, IWP_ACK_OK, id, c->p[id]);
        return;
    }
    case IWP_MSG_SET_PARAM: {
        if (n != IWP_MSG_SET_PARAM_SIZE) break;
        uint8_t id = m[IWP_OFF_SET_PARAM_PARAM];
        uint8_t code = c->state == IWP_STATE_ARMED ? IWP_ACK_ARMED
                                                   : set_param(c, id, get_f32(m + IWP_OFF_SET_PARAM_VALUE));
        ack(c, m, code, id, id < IWP_N_PARAMS ? c->p[id] : 0.0f);
        return;
    }
    case IWP_MSG_ARM: {
        if (n != IWP_MSG_ARM_SIZE) break;
        uint8_t code = IWP_ACK_OK;
        if (c->state == IWP_STATE_FAULT || c->state == IWP_STATE_ESTOP) code = IWP_ACK_FAULT;
        else if (outside_limits(c) != IWP_FAULT_NONE) code = IWP_ACK_LIMIT;
        else {
            if (c->state != IWP_STATE_ARMED) {
                motor_off(c);
                c->state = IWP_STATE_ARMED;
            }
            c->fed_us = c->t_us; /* a repeated ARM (its first ACK lost) feeds the watchdog too */
        }
        ack(c, m, code, 0, 0.0f);
        return;
    }
    case IWP_MSG_DISARM:
        if (n != IWP_MSG_DISARM_SIZE) break;
        if (c->state == IWP_STATE_ARMED) c->state = IWP_STATE_DISARMED;
        motor_off(c);
        ack(c, m, IWP_ACK_OK, 0, 0.0f);
        return;
    case IWP_MSG_ESTOP:
        if (n != IWP_MSG_ESTOP_SIZE) break;
        if (c->state == IWP_STATE_FAULT) motor_off(c); /* the fault that stopped it stays the one reported */
        else trip(c, IWP_FAULT_ESTOP);
        ack(c, m, IWP_ACK_OK, 0, 0.0f);
        return;
    case IWP_MSG_CLEAR:
        if (n != IWP_MSG_CLEAR_SIZE) break;
        if (c->state == IWP_STATE_FAULT || c->state == IWP_STATE_ESTOP) {
            c->state = IWP_STATE_DISARMED;
            c->fault = IWP_FAULT_NONE;
        }
        motor_off(c);
        ack(c, m, IWP_ACK_OK, 0, 0.0f);
        return;
    case IWP_MSG_ZERO: {
        if (n != IWP_MSG_ZERO_SIZE) break;
        if (c->state == IWP_STATE_ARMED) {
            ack(c, m, IWP_ACK_ARMED, 0, 0.0f);
            return;
        }
        uint8_t mask = m[IWP_OFF_ZERO_MASK];
        if (mask & 1) { c->off1 += c->c1; c->c1 = 0; c->q1 = 0.0f; }
        if (mask & 2) { c->off2 += c->c2; c->c2 = 0; }
        c->have_prev = 0;
        ack(c, m, IWP_ACK_OK, 0, 0.0f);
        return;
    }
    case IWP_MSG_COMMAND: {
        if (n != IWP_MSG_COMMAND_SIZE) break;
        uint32_t seq = get_u32(m + IWP_OFF_COMMAND_SEQ);
        if (seq <= c->cmd_seq) break; /* out of order or repeated: refused */
        c->cmd_seq = seq;
        float u = get_f32(m + IWP_OFF_COMMAND_U);
        if (u != u) break; /* NaN is never applied */
        uint32_t tick = get_u32(m + IWP_OFF_COMMAND_TICK);
        c->fed_us = c->t_us; /* the last tick's time: at most one period before the frame arrived */
        if (tick > c->go_tick) c->go_tick = tick;
        if (c->state == IWP_STATE_ARMED && c->mode == IWP_MODE_HOST) enqueue(c, tick, u);
        return;
    }
    case IWP_MSG_HEARTBEAT: {
        if (n != IWP_MSG_HEARTBEAT_SIZE) break;
        uint32_t seq = get_u32(m + IWP_OFF_HEARTBEAT_SEQ);
        if (seq <= c->hb_seq) break;
        c->hb_seq = seq;
        uint32_t tick = get_u32(m + IWP_OFF_HEARTBEAT_TICK);
        c->fed_us = c->t_us;
        if (tick > c->go_tick) c->go_tick = tick;
        return;
    }
    case IWP_MSG_MODE: {
        if (n != IWP_MSG_MODE_SIZE) break;
        uint8_t mode = m[IWP_OFF_MODE_MODE], code = IWP_ACK_OK;
        if (c->state == IWP_STATE_ARMED) code = IWP_ACK_ARMED;
        else if (mode == IWP_MODE_HOST || (mode == IWP_MODE_HOPF && (c->caps & IWP_CAP_HOPF)) ||
                 (mode == IWP_MODE_STATE_FEEDBACK && (c->caps & IWP_CAP_STATE_FEEDBACK)))
            c->mode = mode;
        else code = IWP_ACK_BAD_MODE;
        ack(c, m, code, 0, (float)c->mode);
        return;
    }
    case IWP_MSG_FIXTURE: {
        if (n != IWP_MSG_FIXTURE_SIZE) break;
        uint8_t action = m[IWP_OFF_FIXTURE_ACTION], code = IWP_ACK_OK;
        float q1 = get_f32(m + IWP_OFF_FIXTURE_Q1);
        if (!(c->caps & IWP_CAP_FIXTURE) || action > IWP_FIXTURE_HOLD) code = IWP_ACK_BAD_MODE;
        else if (c->state == IWP_STATE_ARMED && action != IWP_FIXTURE_RELEASE) code = IWP_ACK_ARMED;
        else if (!(q1 == q1) || fabsf(q1) > 100.0f) code = IWP_ACK_OUT_OF_RANGE;
        else {
            c->fixture_pending = 1;
            c->fixture_action = action;
            c->fixture_q1 = q1;
        }
        ack(c, m, code, 0, (float)action);
        return;
    }
    case IWP_MSG_STREAM:
        if (n != IWP_MSG_STREAM_SIZE) break;
        c->stream_every = m[IWP_OFF_STREAM_EVERY];
        ack(c, m, IWP_ACK_OK, 0, (float)c->stream_every);
        return;
    default:
        break;
    }
    c->rx_errors++; /* unknown type, wrong length, out of order or NaN: counted, never applied */
}

static void frame_end(iwp_core_t *c)
{
    if (c->rx_skip) { /* the frame was too long */
        c->rx_skip = 0;
        c->rx_len = 0;
        c->rx_errors++;
        return;
    }
    if (c->rx_len == 0) return;
    int16_t n = iwp_cobs_decode_inplace(c->rx, c->rx_len);
    c->rx_len = 0;
    if (n < 3 || n - 2 > IWP_MAX_PAYLOAD) {
        c->rx_errors++;
        return;
    }
    uint16_t crc = (uint16_t)((c->rx[n - 2] << 8) | c->rx[n - 1]);
    if (iwp_crc16(c->rx, (uint16_t)(n - 2)) != crc) {
        c->rx_errors++;
        return;
    }
    dispatch(c, c->rx, (uint8_t)(n - 2));
}

void iwp_core_rx(iwp_core_t *c, const uint8_t *data, uint16_t n)
{
    for (uint16_t i = 0; i < n; i++) {
        uint8_t b = data[i];
        if (b == 0) {
            frame_end(c);
        } else if (!c->rx_skip) {
            if (c->rx_len == IWP_RX_LEN) c->rx_skip = 1;
            else c->rx[c->rx_len++] = b;
        }
    }
}

void iwp_core_overrun(iwp_core_t *c) { c->overruns++; }

int iwp_core_ready(const iwp_core_t *c)
{
    return c->p[IWP_P_HOST_CLOCK] != 0.0f && c->go_tick > c->tick;
}

/* ------------------------------------------------------------------ the loop */
static float wrap_pi(float x)
{
    x = fmodf(x + PI_F, TWO_PI);
    if (x < 0.0f) x += TWO_PI;
    return x - PI_F;
}

static float clamp_abs(iwp_core_t *c, float x, float lim)
{
    if (x > lim) { c->flags |= IWP_FLAG_SATURATED; return lim; }
    if (x < -lim) { c->flags |= IWP_FLAG_SATURATED; return -lim; }
    return x;
}

float iwp_core_tick(iwp_core_t *c, int32_t count1, int32_t count2, float current, uint32_t t_us)
{
    uint32_t k = ++c->tick;
    c->t_us = t_us;
    c->flags = (uint16_t)(c->flags & IWP_FLAG_QUEUE_FULL);
    if (c->p[IWP_P_HOST_CLOCK] != 0.0f) c->flags |= IWP_FLAG_HOST_CLOCK;
    c->current = current;
    if (current == current) c->flags |= IWP_FLAG_CURRENT_VALID;
    /* sample */
    c->c1 = count1 - c->off1;
    c->c2 = count2 - c->off2;
    c->q1 = (float)c->c1 * c->step1;
    if (c->have_prev) {
        float q3raw = (float)(c->c1 - c->c1_prev) * c->w1;
        c->q3 = c->a3 * c->q3 + (1.0f - c->a3) * q3raw;
        c->q4 = (float)(c->c2 - c->c2_prev) * c->w2;
    } else {
        c->q3 = 0.0f;
        c->q4 = 0.0f;
    }
    c->c1_prev = c->c1;
    c->c2_prev = c->c2;
    c->have_prev = 1;
    if (c->state == IWP_STATE_ARMED) {
        /* the device's own limits: the last line, whatever the host does */
        uint8_t f = outside_limits(c);
        if (f != IWP_FAULT_NONE) trip(c, f);
        /* the watchdog: at most watchdog_ms + one period after the last valid COMMAND or HEARTBEAT */
        else if ((uint32_t)(t_us - c->fed_us) >= c->watchdog_us)
            trip(c, IWP_FAULT_WATCHDOG);
    }
    if (c->state == IWP_STATE_ARMED) {
        float u = c->u;
        if (c->mode == IWP_MODE_HOST) {
            uint8_t got = 0, i = 0;
            while (i < c->n_queue && c->queue[i].tick <= k) { u = c->queue[i].u; got = 1; i++; }
            if (i) {
                memmove(c->queue, c->queue + i, (size_t)(c->n_queue - i) * sizeof(iwp_cmd_t));
                c->n_queue = (uint8_t)(c->n_queue - i);
                c->flags = (uint16_t)(c->flags & ~IWP_FLAG_QUEUE_FULL);
            }
            if (!got) { c->flags |= IWP_FLAG_LATE; c->late++; }
        } else if (c->mode == IWP_MODE_HOPF) {
            float q3 = c->q3;
            u = clamp_abs(c, c->p[IWP_P_K1] * q3 + c->p[IWP_P_K2] * q3 * q3 * q3, c->p[IWP_P_U_MAX]);
        } else {
            float e = wrap_pi(c->q1 - c->p[IWP_P_Q1_REF]);
            u = -(c->p[IWP_P_K_Q1] * e + c->p[IWP_P_K_Q3] * c->q3 + c->p[IWP_P_K_Q4] * c->q4);
            u = clamp_abs(c, u, c->p[IWP_P_U_MAX]);
        }
        /* the feedforward (7)-(8), then the driver's saturation */
        float v = u > 0.0f ? u + c->p[IWP_P_V_DZ_POS] : (u < 0.0f ? u - c->p[IWP_P_V_DZ_NEG] : 0.0f);
        uint16_t before = c->flags;
        c->flags = (uint16_t)(c->flags & ~IWP_FLAG_SATURATED);
        v = clamp_abs(c, v, c->p[IWP_P_V_MAX]);
        /* a stall: the command saturated while the wheel hardly turns (below a tenth of q4_max) */
        if ((c->flags & IWP_FLAG_SATURATED) && fabsf(c->q4) < c->q4_stall)
            c->sat_us += c->period_us;
        else c->sat_us = 0;
        c->flags |= (uint16_t)(before & IWP_FLAG_SATURATED);
        c->u = u;
        c->v = v;
        if (c->sat_max_us && c->sat_us > c->sat_max_us)
            trip(c, IWP_FAULT_DUTY_LIMIT);
    } else {
        motor_off(c);
    }
    if (c->stream_every && k % c->stream_every == 0) telemetry(c);
    return c->v;
}
