/* main.c: the thin hardware layer of iwp's firmware for an ATmega328P board (Arduino Uno/Nano, 16 MHz).
 *
 * Everything the rig does is in the portable core (core/iwp_core.c); this file only connects it to the
 * board (see firmware/README.md for the wiring):
 *   wheel encoder A/B     D2/D3 (INT0/INT1, both edges: 4 counts per line): the fast one on the interrupts
 *                         served first, so that no other interrupt delays its edges by more than one ISR
 *   pendulum encoder A/B  D4/D5 (PCINT20/21, both edges)
 *   H-bridge              PWM D9 (OC1A, 20 kHz), IN1 D10, IN2 D12 (L298N, TB6612, ...): all on PORTB, so that
 *                         the encoders' port D is only read (simavr 1.6 lets a PORTD write override the pins
 *                         its pull-ups feed, which lost and invented encoder edges when IN1 was on D7), and
 *                         not on D8 = ICP1 (simavr 1.6 captures Timer1 into ICR1, the PWM's TOP, on its edges)
 *   current sense         A0 (optional: -DIWP_CURRENT_SENSE, an ACS712-5A by default)
 *   step marker           D13 (high while the control step runs: a scope, or simavr, times it)
 *   serial                500000 baud, 8N1 (the USB adapter of the board); sent from an interrupt
 * Timer2 ticks every millisecond; the loop runs every period_us / 1000 ticks. The AVR's own watchdog
 * (120 ms) resets the board, motor off, if this loop ever hangs; the core's watchdog stops the motor
 * when the host stops sending.
 * Emulated hands: a simulator that presets GPIOR2 to IWP_SIM_HANDS before the first instruction (firmware/sim)
 * gets the FIXTURE capability: each request is handed to it through GPIOR1 (the angle's four bytes, least
 * significant first) and GPIOR0 (the action plus one). A board's GPIOR2 is 0 after a reset: no hands.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include <math.h>
#include <stdint.h>
#include <util/atomic.h>

#include "iwp_core.h"

#ifndef F_CPU
#define F_CPU 16000000UL
#endif
#ifndef IWP_BAUD
#define IWP_BAUD 500000UL
#endif
#define BASE_US 1000UL
#define IWP_SIM_HANDS 0xA5

#ifdef IWP_CURRENT_SENSE
#define CAPS (IWP_CAP_HOPF | IWP_CAP_STATE_FEEDBACK | IWP_CAP_CURRENT)
#ifndef IWP_AMPS_PER_COUNT /* ACS712-5A: 185 mV/A at 5 V / 1024 counts */
#define IWP_AMPS_PER_COUNT (5.0f / 1024.0f / 0.185f)
#endif
#define IWP_CURRENT_ZERO 512
#else
#define CAPS (IWP_CAP_HOPF | IWP_CAP_STATE_FEEDBACK)
#endif

static iwp_core_t core;

/* ------------------------------------------------------------------ encoders (x4 quadrature)
 * The interrupts keep 16-bit counts (few registers to save: an edge costs about half the cycles of a 32-bit
 * count) and the loop extends them to 32 bits at every tick: exact while fewer than 32768 edges come between
 * two ticks (1.6 million edges/s at the longest period, 20 ms). */
/* QUAD[4 * old + new]: +1, -1, 0 (no change), or 2: both lines changed, one edge came before the interrupt read
 * the first (its latency behind another interrupt, about 60 cycles each, longer than the edges' spacing): the
 * encoder went on the way it was going, two counts (a reversal exactly then would be 4 counts off; at the
 * speeds where edges come that close, it does not reverse). Exact while no line changes twice before its read. */
static const int8_t QUAD[16] = {0, -1, 1, 2, 1, 0, 2, -1, -1, 2, 0, 1, 2, 1, -1, 0};
static volatile uint16_t count1, count2; /* wrap around; see encoder_counts() */
static volatile uint8_t ab1, ab2;        /* the last A/B state, times 4 (QUAD's row) */
static int8_t dir1, dir2;                /* the last direction counted, +1 or -1 (0: none yet) */

/* the count's step for the lines' new state ab (0-3); prev and dir: the encoder's last state and direction */
static inline int8_t quad_step(uint8_t ab, volatile uint8_t *prev, int8_t *dir)
{
    int8_t d = QUAD[*prev | ab];
    if (d == 2) d = (int8_t)(*dir + *dir);
    else if (d) *dir = d;
    *prev = (uint8_t)(ab << 2);
    return d;
}

ISR(INT0_vect) { count2 += quad_step((uint8_t)((PIND >> 2) & 3), &ab2, &dir2); } /* D2 = A, D3 = B: the wheel */
ISR(INT1_vect, ISR_ALIASOF(INT0_vect));
ISR(PCINT2_vect) { count1 += quad_step((uint8_t)((PIND >> 4) & 3), &ab1, &dir1); } /* D4, D5: the pendulum */

static int32_t total1, total2;
static uint16_t last1, last2;

/* the 32-bit counts from the 16-bit ones read at this tick */
static void encoder_counts(uint16_t r1, uint16_t r2)
{
    total1 += (int16_t)(uint16_t)(r1 - last1);
    total2 += (int16_t)(uint16_t)(r2 - last2);
    last1 = r1;
    last2 = r2;
}

/* ------------------------------------------------------------------ the clock: Timer2, 1 kHz */
static volatile uint32_t ms;
static volatile uint8_t due, missed;
static volatile uint16_t every = 5, phase;

ISR(TIMER2_COMPA_vect)
{
    ms++;
    if (++phase >= every) {
        phase = 0;
        if (due) missed++; /* the last step has not run yet: an overrun */
        due = 1;
    }
}

static uint32_t micros(void)
{
    uint32_t m;
    uint8_t t;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { m = ms; t = TCNT2; }
    return m * 1000UL + (uint32_t)t * 4UL;
}

/* ------------------------------------------------------------------ serial, interrupt driven */
#define RX_LEN 64
static volatile uint8_t rx_buf[RX_LEN], rx_head, rx_tail;
ISR(USART_RX_vect)
{
    uint8_t b = UDR0, next = (uint8_t)((rx_head + 1) & (RX_LEN - 1));
    if (next != rx_tail) { rx_buf[rx_head] = b; rx_head = next; } /* else lost: the frame's CRC fails */
}

#define TX_LEN 128 /* sent by the UDRE interrupt, also while the control step runs */
static volatile uint8_t tx_buf[TX_LEN], tx_head, tx_tail;
ISR(USART_UDRE_vect)
{
    if (tx_tail == tx_head) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0); /* nothing more to send */
        return;
    }
    UDR0 = tx_buf[tx_tail];
    tx_tail = (uint8_t)((tx_tail + 1) & (TX_LEN - 1));
}

/* move what the core has to send into the interrupt's buffer */
static void uart_feed(void)
{
    uint8_t moved = 0;
    while (iwp_core_tx_pending(&core)) {
        uint8_t next = (uint8_t)((tx_head + 1) & (TX_LEN - 1));
        if (next == tx_tail) break;
        uint8_t b;
        iwp_core_tx_take(&core, &b, 1);
        tx_buf[tx_head] = b;
        tx_head = next;
        moved = 1;
    }
    if (moved) UCSR0B |= _BV(UDRIE0);
}

static void uart_init(void)
{
    UCSR0A = _BV(U2X0);
    UBRR0 = (uint16_t)(F_CPU / (8UL * IWP_BAUD) - 1UL);
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
}

/* ------------------------------------------------------------------ the motor */
#define PWM_TOP 400 /* 16 MHz / (2 * 400) = 20 kHz, phase correct */

static void motor_init(void)
{
    DDRB |= _BV(PB1) | _BV(PB2) | _BV(PB4) | _BV(PB5); /* D9 PWM, D10 IN1, D12 IN2, D13 step marker */
    TCCR1A = _BV(COM1A1) | _BV(WGM11);
    TCCR1B = _BV(WGM13) | _BV(CS10);
    ICR1 = PWM_TOP;
    OCR1A = 0;
}

static void motor_set(float v) /* v in input units, |v| <= 100 = full duty */
{
    float a = v < 0.0f ? -v : v;
    uint16_t duty = (uint16_t)(a * (PWM_TOP / 100.0f) + 0.5f);
    if (duty > PWM_TOP) duty = PWM_TOP;
    uint8_t dir = v > 0.0f ? _BV(PB2) : v < 0.0f ? _BV(PB4) : 0; /* IN1 D10 for v > 0, IN2 D12 for v < 0 */
    PORTB = (uint8_t)((PORTB & (uint8_t)~(_BV(PB2) | _BV(PB4))) | dir);
    OCR1A = duty;
}

static float current_amps(void)
{
#ifdef IWP_CURRENT_SENSE
    ADCSRA |= _BV(ADSC);
    while (ADCSRA & _BV(ADSC)) {}
    return ((int16_t)ADC - IWP_CURRENT_ZERO) * IWP_AMPS_PER_COUNT;
#else
    return NAN;
#endif
}

static void io_init(void)
{
    /* encoders: inputs with pull-ups, interrupts on any edge */
    DDRD &= (uint8_t)~(_BV(PD2) | _BV(PD3) | _BV(PD4) | _BV(PD5));
    PORTD |= _BV(PD2) | _BV(PD3) | _BV(PD4) | _BV(PD5);
    EICRA = _BV(ISC00) | _BV(ISC10);
    EIMSK = _BV(INT0) | _BV(INT1);
    PCMSK2 = _BV(PCINT20) | _BV(PCINT21);
    PCICR = _BV(PCIE2);
    ab2 = (uint8_t)(((PIND >> 2) & 3) << 2); /* the wheel on D2/D3 */
    ab1 = (uint8_t)(((PIND >> 4) & 3) << 2); /* the pendulum on D4/D5 */
    /* Timer2: CTC, 16 MHz / 64 / 250 = 1 kHz */
    TCCR2A = _BV(WGM21);
    TCCR2B = _BV(CS22);
    OCR2A = 249;
    TIMSK2 = _BV(OCIE2A);
#ifdef IWP_CURRENT_SENSE
    ADMUX = _BV(REFS0);
    ADCSRA = _BV(ADEN) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);
#endif
}

/* the emulated hands of a simulator (see the top of this file) */
static void hands_request(uint8_t action, float q1)
{
    const uint8_t *b = (const uint8_t *)&q1;
    for (uint8_t i = 0; i < 4; i++) GPIOR1 = b[i];
    GPIOR0 = (uint8_t)(action + 1);
}

int main(void)
{
    uint8_t hands = GPIOR2 == IWP_SIM_HANDS;
    MCUSR = 0;
    wdt_enable(WDTO_120MS);
    motor_init();
    motor_set(0.0f);
    iwp_core_init(&core, 1, hands ? CAPS | IWP_CAP_FIXTURE : CAPS, BASE_US);
    uart_init();
    io_init();
    sei();
    for (;;) {
        wdt_reset();
        if (due) {
            uint16_t c1, c2;
            uint8_t lost;
            ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
                PORTB |= _BV(PB5); /* the control step starts: the counts are those of this instant */
                c1 = count1; c2 = count2; due = 0; lost = missed; missed = 0;
            }
            while (lost--) iwp_core_overrun(&core);
            encoder_counts(c1, c2);
            float v = iwp_core_tick(&core, total1, total2, current_amps(), micros());
            motor_set(v);
            PORTB &= (uint8_t)~_BV(PB5); /* ... and ends */
            uint16_t per = (uint16_t)(iwp_core_period_us(&core) / BASE_US);
            ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { every = per ? per : 1; }
        }
        while (rx_tail != rx_head) {
            uint8_t b = rx_buf[rx_tail];
            rx_tail = (uint8_t)((rx_tail + 1) & (RX_LEN - 1));
            iwp_core_rx(&core, &b, 1);
        }
        uint8_t action;
        float q1;
        if (hands && iwp_core_fixture(&core, &action, &q1)) hands_request(action, q1);
        uart_feed();
        ATOMIC_BLOCK(ATOMIC_FORCEON) {
            uint8_t tx_full = ((uint8_t)(tx_head + 1) & (TX_LEN - 1)) == tx_tail;
            if (!due && rx_tail == rx_head && (!iwp_core_tx_pending(&core) || tx_full)) {
                set_sleep_mode(SLEEP_MODE_IDLE);
                sleep_enable();
                sei();
                sleep_cpu(); /* the next interrupt wakes it: a tick, a byte */
                sleep_disable();
            }
        }
    }
}
