/* iwp_core.h: the portable core of iwp's rig firmware.
 *
 * The protocol (iwp_protocol.h, generated from iwp.device.protocol), the state
 * machine (DISARMED, ARMED, FAULT, ESTOP), the parameters, the command queue,
 * the watchdog, the limits and the control laws (the host's input, the Hopf law
 * of section 5.3, state feedback such as the upright LQR), with the feedforward
 * (7)-(8) and the driver's saturation. No hardware, no allocation, no clock of
 * its own: the hardware layer (firmware/avr/, or the host's emulator through
 * ctypes) feeds it received bytes, calls iwp_core_tick() once per loop period
 * with the encoder counts and the device time, applies the returned command to
 * the motor driver, and sends the bytes of iwp_core_tx_take().
 */
#ifndef IWP_CORE_H
#define IWP_CORE_H

#include <stdint.h>

#include "iwp_protocol.h"

#define IWP_FW_MAJOR 1
#define IWP_FW_MINOR 0
#define IWP_FW_PATCH 0

#define IWP_QUEUE_LEN 8   /* queued COMMANDs (by tick) */
#define IWP_RX_LEN 80     /* one stuffed frame between delimiters */
#define IWP_TX_LEN 256    /* outgoing bytes (a power of two) */

typedef struct {
    uint32_t tick;
    float u;
} iwp_cmd_t;

typedef struct {
    /* board constants (iwp_core_init) */
    uint8_t board;
    uint16_t caps;
    uint32_t base_us;
    /* parameters (IWP_P_*) and values derived from them */
    float p[IWP_N_PARAMS];
    float step1, step2; /* encoder steps [rad] */
    float dt;           /* loop period [s] */
    float w1, w2;       /* count differences to speeds: step / dt [rad/s per count] */
    float a3;           /* q3 filter pole exp(-dt/tau) */
    float q4_stall;     /* below this wheel speed a saturated command is a stall [rad/s] */
    uint32_t period_us, watchdog_us, sat_max_us; /* the same parameters as integers, once */
    /* state machine */
    uint8_t state, fault, mode, stream_every;
    uint32_t tick;         /* ticks since boot; the first is 1 */
    uint32_t t_us;         /* device time of the last tick */
    uint32_t fed_us;       /* device time of the last tick before the last valid COMMAND/HEARTBEAT */
    uint32_t cmd_seq, hb_seq;
    uint32_t go_tick;      /* host clock: the device may run up to this tick */
    iwp_cmd_t queue[IWP_QUEUE_LEN];
    uint8_t n_queue;
    /* signals */
    int32_t off1, off2, c1, c2, c1_prev, c2_prev;
    uint8_t have_prev;
    float q1, q3, q4, u, v, current;
    uint32_t sat_us;
    uint8_t fixture_pending, fixture_action;
    float fixture_q1;
    uint16_t flags, overruns, late, rx_errors, dropped;
    /* link */
    uint8_t rx[IWP_RX_LEN];
    uint8_t rx_len, rx_skip;
    uint8_t tx[IWP_TX_LEN];
    uint16_t tx_head, tx_tail;
} iwp_core_t;

/* Reset everything; parameters to their defaults. board: IDENT board; caps: IWP_CAP_* the board has;
 * base_us: the tick granularity of the hardware layer (period_us must be a multiple). */
void iwp_core_init(iwp_core_t *c, uint8_t board, uint16_t caps, uint32_t base_us);

/* Bytes received from the host (call from the main loop, not from an interrupt). */
void iwp_core_rx(iwp_core_t *c, const uint8_t *data, uint16_t n);

/* One loop period: raw encoder counts, motor current [A] (NaN: not measured) and the device time [us].
 * Returns the driver command v to apply now [input units, |v| <= v_max; 100 = full duty]. */
float iwp_core_tick(iwp_core_t *c, int32_t count1, int32_t count2, float current, uint32_t t_us);

/* The hardware layer missed a period (the loop ran late). */
void iwp_core_overrun(iwp_core_t *c);

/* Host clock (param host_clock = 1, caps HOST_CLOCK): 1 when the host allows the next tick now. */
int iwp_core_ready(const iwp_core_t *c);

/* The value of parameter id (IWP_P_*; 0 for an unknown id), for a hardware layer that follows one. */
float iwp_core_param(const iwp_core_t *c, uint8_t id);

/* The loop period [us]. */
uint32_t iwp_core_period_us(const iwp_core_t *c);

/* Move up to max bytes to send into buf; returns how many. */
uint16_t iwp_core_tx_take(iwp_core_t *c, uint8_t *buf, uint16_t max);
/* Bytes waiting to be sent. */
uint16_t iwp_core_tx_pending(const iwp_core_t *c);

/* FNV-1a of the parameter values (IDENT params_hash). */
uint32_t iwp_core_params_hash(const iwp_core_t *c);

/* A FIXTURE request (emulated rigs only, caps FIXTURE): returns 1 once per request, with its action and angle. */
int iwp_core_fixture(iwp_core_t *c, uint8_t *action, float *q1);

/* The tick, state, fault and applied command, for a hardware layer that shows them. */
void iwp_core_status(const iwp_core_t *c, uint32_t *tick, uint8_t *state, uint8_t *fault, float *v);

/* The size of iwp_core_t (for bindings that allocate it). */
uint32_t iwp_core_size(void);

#endif
