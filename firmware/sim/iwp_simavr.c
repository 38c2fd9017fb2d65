/* iwp_simavr.c: run iwp's AVR firmware under simavr, its serial port on a pseudo-terminal.
 *
 *     iwp_simavr FIRMWARE.elf [--stats FILE] [--spin HZ]
 *     iwp_simavr FIRMWARE.elf --twin COUNTS_PER_REV [--chunk-us US] [--gap CYCLES] [--stats FILE]
 *
 * Prints "port: /dev/pts/N" once the port is ready; the host then talks to it as to a board
 * (iwp rig run ... --port /dev/pts/N). The step marker D13 (PB5) is watched: the number of cycles between
 * its rising and falling edges is the control step's cost, in simavr's cycle count, written as JSON to
 * --stats every simulated second and at the end. SIGINT/SIGTERM stop it. Links against Debian's
 * libsimavr-dev (simavr, simavrparts).
 *
 * --spin HZ turns the pendulum's encoder at HZ edges per second (and the wheel's at 5 times that), so that
 * the step and the encoder interrupts do real work; the simulation is paced in real time.
 *
 * --twin: the plant sits at the pins (the pin-level twin). A plant on the other side of stdin/stdout (iwp's
 * twin, iwp.device.pins) is stepped in simulated time, one chunk at a time:
 *   this program writes   "T CYCLE V HAND Q1 HORIZON"   the simulation is at CYCLE; the motor's input V
 *                         [input units] holds from CYCLE on; HAND: 0, or an emulated hand's action plus one
 *                         at CYCLE (with its angle Q1 [rad]); the next chunk ends at cycle HORIZON
 *   the plant answers     "Q1 Q3 Q2 Q4 P1 P3 P2 P4"   its angles [rad] and speeds [rad/s] at CYCLE and, V held,
 *                         predicted at HORIZON
 * and, on every rising edge of the step marker (the instant the firmware reads its counts), writes
 *                         "M TICK CYCLE N1 N2 S1 S2"   the counts put on the pins so far (relative to the
 *                         first tick), and S: those the pins showed when the encoder's interrupt last read
 *                         them (PIND): what the firmware must have counted; an edge still pending behind the
 *                         read makes S differ from N
 * The encoders' quadrature edges (x4: COUNTS_PER_REV counts per turn, count n = round(q / step)) are placed
 * where the cubic (Hermite) interpolation of the angles and speeds between the chunk's ends crosses
 * (n +- 1/2) step (the wheel's belt rings at ~100 Hz: a straight line over a chunk of 1 ms was wrong by up to
 * several counts, which then came as bursts of edges that the firmware could not all count); a jump of
 * the plant (the hands holding the pendulum at an angle) is caught up one edge every --gap cycles (800), or at
 * twice the angle's rate if that is faster; no two edges come closer than that. The motor's
 * input is read back from the pins and registers: OCR1A / ICR1 of the PWM on D9 (if D9 is an output driven by
 * OC1A) signed by the direction pins IN1 D10 / IN2 D12. A change of it, or a hand, ends the chunk at once, so
 * that the plant holds each input exactly from the cycle the firmware set it. The chunk is --chunk-us long
 * (1000). The emulated hands (GPIOR2 preset, see avr/main.c) are plugged in. The simulation runs as fast as
 * it can while the host keeps talking: at most half a loop period (at least 1 ms) of simulated time beyond the
 * end of the first frame the host has not answered yet (no byte from the host since); so a host that answers
 * each tick's telemetry with the next tick's command is on time at 200 Hz, however slow the computer (at
 * 1 kHz, such a command may be late). A host silent for SILENT (0.25 s) of wall-clock time no longer
 * holds it: it goes on in real time (the firmware's watchdog stops the motor as on a board).
 */
#include <errno.h>
#include <stdint.h>
#include <fcntl.h>
#include <math.h>
#include <pty.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_interrupts.h"
#include "sim_time.h"
#include "uart_pty.h"

/* ATmega328P data-space addresses */
#define A_DDRB 0x24
#define A_PORTB 0x25
#define A_GPIOR0 0x3E
#define A_GPIOR1 0x4A
#define A_GPIOR2 0x4B
#define A_TCCR1A 0x80
#define A_ICR1L 0x86
#define A_OCR1AL 0x88
#define SIM_HANDS 0xA5 /* IWP_SIM_HANDS of avr/main.c */
#define SILENT 0.25 /* s of wall-clock time the simulation waits for a silent host, then goes on in real time */

static avr_t *avr;
static uart_pty_t pty;
static volatile sig_atomic_t stop;
static avr_cycle_count_t started, steps, total, worst, last_write;
static const char *stats_path;
static avr_cycle_count_t spin_period;
static int spin_phase;
static avr_irq_t *pins_d;
static long long caught_up[2]; /* edges put on the pins behind the angle (a jump, or a late edge) */

static void on_signal(int s) { (void)s; stop = 1; }

static void write_stats(void)
{
    if (!stats_path) return;
    char tmp[512];
    snprintf(tmp, sizeof tmp, "%s.tmp", stats_path);
    FILE *f = fopen(tmp, "w");
    if (!f) return;
    fprintf(f, "{\"frequency\": %u, \"steps\": %llu, \"cycles_mean\": %.1f, \"cycles_max\": %llu, "
               "\"cycles\": %llu, \"caught_up\": [%lld, %lld]}\n",
            avr->frequency, (unsigned long long)steps, steps ? (double)total / (double)steps : 0.0,
            (unsigned long long)worst, (unsigned long long)avr->cycle, caught_up[0], caught_up[1]);
    fclose(f);
    rename(tmp, stats_path);
}

/* ------------------------------------------------------------------ the twin's encoders */
static const uint8_t FWD[4] = {0, 2, 3, 1}; /* A = bit 0, B = bit 1; counting up as avr/main.c's QUAD does */
#define PIECES 32                           /* the chunk's cubic is followed in this many straight pieces */

typedef struct {
    avr_irq_t *a, *b;
    double step;                  /* rad per count */
    int connected;                /* from the first tick on */
    long long n0, n;              /* count of the first tick; counts put on the pins since */
    avr_cycle_count_t ca, cb;     /* the chunk: from cycle ca to cb, the angle is the cubic (Hermite) through */
    double qa, va, qb, vb;        /* qa, qb with the speeds va, vb [rad/s] at its ends */
    avr_cycle_count_t last_edge;
    long long seen;               /* the count of the pins when the firmware's interrupt last read them */
} encoder_t;

static encoder_t enc[2];
static avr_cycle_count_t gap = 800; /* 20,000 edges/s: well inside what the firmware counts */
static int twin;

static double angle_at(const encoder_t *e, avr_cycle_count_t c)
{
    if (c >= e->cb || e->cb == e->ca) return e->qb;
    if (c <= e->ca) return e->qa;
    double h = (double)(e->cb - e->ca) / avr->frequency, s = (double)(c - e->ca) / (double)(e->cb - e->ca);
    double s2 = s * s, s3 = s2 * s;
    return (2 * s3 - 3 * s2 + 1) * e->qa + (s3 - 2 * s2 + s) * h * e->va + (3 * s2 - 2 * s3) * e->qb +
           (s3 - s2) * h * e->vb;
}

static long long count_at(const encoder_t *e, avr_cycle_count_t c)
{
    return llround(angle_at(e, c) / e->step) - e->n0;
}

static void put_pins(encoder_t *e)
{
    uint8_t ab = FWD[(e->n + 2) & 3]; /* count 0: A = B = 1, as the pull-ups hold them at reset */
    avr_raise_irq(e->a, ab & 1);
    avr_raise_irq(e->b, (ab >> 1) & 1);
    e->last_edge = avr->cycle;
}

/* the cycle at which the angle next leaves the count's half-step band, or 0 (not within this chunk): along the
 * cubic in straight pieces of 1/PIECES of the chunk */
static avr_cycle_count_t next_crossing(const encoder_t *e, avr_cycle_count_t now)
{
    if (now >= e->cb) return 0;
    double lo = ((double)(e->n + e->n0) - 0.5) * e->step, hi = lo + e->step;
    double span = (double)(e->cb - e->ca) / PIECES;
    avr_cycle_count_t c0 = now;
    double q0 = angle_at(e, c0);
    for (int k = (int)((double)(now - e->ca) / span) + 1; k <= PIECES; k++) {
        avr_cycle_count_t c1 = k == PIECES ? e->cb : e->ca + (avr_cycle_count_t)llround(k * span);
        if (c1 <= c0) continue;
        double q1 = angle_at(e, c1);
        double thr = q1 >= hi ? hi : q1 < lo ? lo : NAN;
        if (thr == thr) {
            double c = (double)c0 + (q1 != q0 ? (thr - q0) / (q1 - q0) : 1.0) * (double)(c1 - c0);
            avr_cycle_count_t when = (avr_cycle_count_t)ceil(c);
            return when > now ? when : now + 1;
        }
        c0 = c1;
        q0 = q1;
    }
    return 0;
}

static avr_cycle_count_t encoder_timer(struct avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)when;
    encoder_t *e = (encoder_t *)param;
    long long want = count_at(e, a->cycle);
    if (want != e->n) {
        /* never two edges closer than half the spacing at the chunk's speed (nor than gap): a chunk's start may
         * find the angle a count past the edge just put on the pins, which no encoder does; behind the angle,
         * edges follow at that spacing, twice the angle's rate, so that they catch up */
        double v = fabs(e->va) > fabs(e->vb) ? fabs(e->va) : fabs(e->vb);
        double spacing = v > 0 ? 0.5 * e->step / v * a->frequency : (double)gap;
        avr_cycle_count_t least = (avr_cycle_count_t)(spacing < (double)gap ? spacing : (double)gap);
        if (least < 1) least = 1;
        if (e->last_edge && a->cycle < e->last_edge + least) return e->last_edge + least;
        if (want - e->n > 1 || e->n - want > 1) caught_up[e == &enc[1]]++;
        e->n += want > e->n ? 1 : -1;
        put_pins(e);
        if (want != e->n) return a->cycle + least; /* behind: catch up */
    }
    return next_crossing(e, a->cycle);
}

static void encoder_chunk(encoder_t *e, avr_cycle_count_t ca, const double qv[2], avr_cycle_count_t cb,
                          const double qvb[2])
{
    e->ca = ca, e->qa = qv[0], e->va = qv[1], e->cb = cb, e->qb = qvb[0], e->vb = qvb[1];
    if (!e->connected) return;
    avr_cycle_timer_cancel(avr, encoder_timer, e);
    avr_cycle_timer_register(avr, 1, encoder_timer, e);
}

/* which encoder's interrupt runs (its next read of PIND samples that encoder's pins) */
static int reading = -1;

static void on_vector(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    if (value) reading = (int)(intptr_t)param;
}

static void on_pind_read(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)value; (void)param;
    if (reading >= 0) {
        enc[reading].seen = enc[reading].n;
        reading = -1;
    }
}

/* ------------------------------------------------------------------ the motor's input and the hands */
static double motor_input(void)
{
    const uint8_t *d = avr->data;
    if (!(d[A_DDRB] & 0x02) || !(d[A_TCCR1A] & 0x80)) return 0.0; /* D9 not an output, or OC1A off */
    unsigned top = d[A_ICR1L] | (d[A_ICR1L + 1] << 8), ocr = d[A_OCR1AL] | (d[A_OCR1AL + 1] << 8);
    if (!top) return 0.0;
    double duty = 100.0 * (ocr < top ? ocr : top) / top;
    uint8_t out = d[A_PORTB] & d[A_DDRB];
    int in1 = (out >> 2) & 1, in2 = (out >> 4) & 1; /* IN1 D10 = PB2, IN2 D12 = PB4 */
    return in1 && !in2 ? duty : in2 && !in1 ? -duty : 0.0;
}

static uint8_t hand_bytes[4], hand_action;
static float hand_q1;

static void hands_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    a->data[addr] = v;
    if (addr == A_GPIOR1) {
        memmove(hand_bytes, hand_bytes + 1, 3);
        hand_bytes[3] = v;
    } else if (v) {
        memcpy(&hand_q1, hand_bytes, 4); /* both little-endian */
        hand_action = v;
    }
}

/* ------------------------------------------------------------------ the serial port, in this thread
 * (simavr's uart_pty part feeds the UART from a thread of its own, which races the simulation: bytes were lost
 * and cycle timers corrupted when the simulation ran faster than real time) */
static int pty_fd = -1;
static char pty_name[128];
static avr_irq_t *uart_in;
static uint8_t to_host[16384], from_host[4096];
static size_t to_host_len, from_host_len, from_host_done;
static int uart_xon = 1;
static avr_cycle_count_t said_cycle, period_cycles = 5 * 16000, last_tick;
static double host_wall;
static long long ticks;

static double wall(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void feed_uart(void)
{
    while (uart_xon && from_host_done < from_host_len) {
        avr_raise_irq(uart_in, from_host[from_host_done++]);
        said_cycle = 0; /* the host has answered */
        host_wall = wall();
    }
}

static void on_uart_out(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)param;
    if (to_host_len < sizeof to_host) to_host[to_host_len++] = (uint8_t)value; /* else lost, as on a full line */
    if (value == 0 && !said_cycle) said_cycle = avr->cycle; /* the end of a frame the host has not answered */
}

static void on_xon(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)value; (void)param;
    uart_xon = 1;
    feed_uart();
}

static void on_xoff(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)value; (void)param;
    uart_xon = 0;
}

/* move bytes between the pseudo-terminal and the UART; 1 if bytes from the host wait to go in */
static int pty_poll(void)
{
    if (to_host_len) {
        ssize_t n = write(pty_fd, to_host, to_host_len);
        if (n > 0) {
            memmove(to_host, to_host + n, to_host_len - (size_t)n);
            to_host_len -= (size_t)n;
        } else if (n < 0 && errno != EAGAIN) {
            to_host_len = 0; /* nobody on the other side */
        }
    }
    if (from_host_done == from_host_len) {
        ssize_t n = read(pty_fd, from_host, sizeof from_host);
        from_host_done = 0;
        from_host_len = n > 0 ? (size_t)n : 0;
    }
    feed_uart();
    return from_host_done < from_host_len;
}

static int pty_open(void)
{
    int slave;
    if (openpty(&pty_fd, &slave, pty_name, NULL, NULL) < 0) return -1;
    struct termios tio;
    tcgetattr(pty_fd, &tio);
    cfmakeraw(&tio);
    tcsetattr(pty_fd, TCSANOW, &tio);
    close(slave);
    fcntl(pty_fd, F_SETFL, fcntl(pty_fd, F_GETFL) | O_NONBLOCK);
    uint32_t f = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &f);
    f &= ~AVR_UART_FLAG_STDIO;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &f);
    uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), on_uart_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), on_xon, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), on_xoff, NULL);
    return 0;
}

/* may the simulation go on from cycle c now? */
static int allowed(avr_cycle_count_t c)
{
    if (!said_cycle) return 1; /* no frame out since the host's last byte */
    double lead = 0.5 * (double)period_cycles; /* at 200 Hz, a command for the next tick is on time */
    if (lead < 1e-3 * avr->frequency) lead = 1e-3 * avr->frequency;
    double silent = wall() - host_wall - SILENT; /* a silent host: real time after SILENT seconds */
    if (silent > 0) lead += silent * avr->frequency;
    return (double)c <= (double)said_cycle + lead;
}

/* ------------------------------------------------------------------ the step marker */
static void marker(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)param;
    if (value) {
        started = avr->cycle;
        ticks++;
        if (last_tick) period_cycles = avr->cycle - last_tick;
        last_tick = avr->cycle;
        if (!twin) return;
        for (int i = 0; i < 2; i++) {
            if (!enc[i].connected) { /* the firmware has set its pins up: count 0 from here */
                enc[i].connected = 1;
                enc[i].n0 = llround(angle_at(&enc[i], avr->cycle) / enc[i].step);
                enc[i].n = enc[i].seen = 0;
                avr_cycle_timer_register(avr, 1, encoder_timer, &enc[i]);
            }
        }
        printf("M %lld %llu %lld %lld %lld %lld\n", ticks, (unsigned long long)avr->cycle, enc[0].n, enc[1].n,
               enc[0].seen, enc[1].seen);
    } else if (started) {
        avr_cycle_count_t c = avr->cycle - started;
        steps++;
        total += c;
        if (c > worst) worst = c;
        started = 0;
    }
}

/* quadrature: the pendulum's A/B on D4/D5 every spin_period cycles, the wheel's D2/D3 five times as often */
static avr_cycle_count_t spin(struct avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a; (void)param;
    static const uint8_t gray[4] = {0, 1, 3, 2};
    spin_phase++;
    uint8_t w = gray[spin_phase & 3];
    avr_raise_irq(pins_d + 2, w & 1);
    avr_raise_irq(pins_d + 3, (w >> 1) & 1);
    if (spin_phase % 5 == 0) {
        uint8_t p = gray[(spin_phase / 5) & 3];
        avr_raise_irq(pins_d + 4, p & 1);
        avr_raise_irq(pins_d + 5, (p >> 1) & 1);
    }
    return when + spin_period / 5;
}

/* ------------------------------------------------------------------ the twin's loop */
static avr_cycle_count_t chunk_end_timer(struct avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a; (void)param;
    /* only so that a sleeping core stops at the chunk's end: simavr, having run this timer, sleeps on to the
     * next timer in the same step, and past the chunk's end no encoder timer is left (each stops at its
     * chunk's end), so that a core asleep here slept up to the next Timer2 tick with the encoders' pins frozen
     * (up to 1 ms: the wheel's count then came as a burst of edges at twice its rate, which the firmware could
     * not all count). Due again one cycle later, it keeps that sleep to one cycle; the loop cancels it. */
    return when + 1;
}

static void no_sleep(struct avr_t *a, avr_cycle_count_t howLong) { (void)a; (void)howLong; }

static int run_twin(avr_cycle_count_t chunk)
{
    int state = cpu_Running;
    double v = motor_input();
    avr->sleep = no_sleep; /* paced below, not by sleeping */
    host_wall = wall();
    for (;;) {
        avr_cycle_count_t now = avr->cycle, horizon = now + chunk;
        printf("T %llu %.9g %u %.9g %llu\n", (unsigned long long)now, v, hand_action, hand_action ? hand_q1 : 0.0f,
               (unsigned long long)horizon);
        fflush(stdout);
        hand_action = 0;
        double q[8]; /* q1 q3 q2 q4 now, then at the horizon */
        for (int i = 0; i < 8; i++)
            if (scanf("%lf", &q[i]) != 1) return state; /* the plant has gone */
        encoder_chunk(&enc[0], now, q, horizon, q + 4);
        encoder_chunk(&enc[1], now, q + 2, horizon, q + 6);
        while (!pty_poll() && !allowed(now) && !stop) usleep(100); /* the chunk may overshoot the lead */
        avr_cycle_timer_register(avr, chunk, chunk_end_timer, NULL);
        while (avr->cycle < horizon && !stop) {
            state = avr_run(avr);
            if (state == cpu_Done || state == cpu_Crashed) return state;
            double v2 = motor_input();
            if (v2 != v || hand_action) { /* the plant takes the new input from this cycle */
                v = v2;
                break;
            }
        }
        avr_cycle_timer_cancel(avr, chunk_end_timer, NULL);
        if (stop) return state;
        if (avr->cycle - last_write >= avr->frequency) {
            last_write = avr->cycle;
            write_stats();
        }
    }
}

int main(int argc, char **argv)
{
    const char *fw = NULL;
    double spin_hz = 0.0, counts = 0.0, chunk_us = 1000.0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--stats") && i + 1 < argc) stats_path = argv[++i];
        else if (!strcmp(argv[i], "--spin") && i + 1 < argc) spin_hz = atof(argv[++i]);
        else if (!strcmp(argv[i], "--twin") && i + 1 < argc) counts = atof(argv[++i]);
        else if (!strcmp(argv[i], "--chunk-us") && i + 1 < argc) chunk_us = atof(argv[++i]);
        else if (!strcmp(argv[i], "--gap") && i + 1 < argc) gap = (avr_cycle_count_t)atoll(argv[++i]);
        else fw = argv[i];
    }
    if (!fw || (counts != 0.0 && !(counts >= 4.0)) || !(chunk_us >= 1.0) || gap < 1) {
        fprintf(stderr, "usage: %s FIRMWARE.elf [--stats FILE] [--spin HZ | --twin COUNTS_PER_REV "
                        "[--chunk-us US] [--gap CYCLES]]\n", argv[0]);
        return 2;
    }
    elf_firmware_t f;
    memset(&f, 0, sizeof f);
    if (elf_read_firmware(fw, &f) != 0) {
        fprintf(stderr, "iwp_simavr: cannot read %s\n", fw);
        return 2;
    }
    if (!f.mmcu[0]) strcpy(f.mmcu, "atmega328p");
    if (!f.frequency) f.frequency = 16000000;
    avr = avr_make_mcu_by_name(f.mmcu);
    if (!avr) {
        fprintf(stderr, "iwp_simavr: unknown MCU %s\n", f.mmcu);
        return 2;
    }
    avr_init(avr);
    avr_load_firmware(avr, &f);
    twin = counts != 0.0;
    if (twin ? pty_open() != 0 : (uart_pty_init(avr, &pty), uart_pty_connect(&pty, '0'), 0)) {
        fprintf(stderr, "iwp_simavr: cannot open a pseudo-terminal: %s\n", strerror(errno));
        return 1;
    }
    printf("port: %s\n", twin ? pty_name : pty.pty.slavename);
    fflush(stdout);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), 5), marker, NULL);
    pins_d = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), 0);
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    int state = cpu_Running;
    if (twin) {
        for (int i = 0; i < 2; i++) {
            enc[i].a = pins_d + 4 - 2 * i; /* pendulum D4/D5, wheel D2/D3 */
            enc[i].b = pins_d + 5 - 2 * i;
            enc[i].step = 2.0 * M_PI / counts;
        }
        avr->data[A_GPIOR2] = SIM_HANDS;
        avr_register_io_write(avr, A_GPIOR0, hands_write, NULL);
        avr_register_io_write(avr, A_GPIOR1, hands_write, NULL);
        /* INT0/INT1 (vectors 1, 2) read the wheel's pins, PCINT2 (5) the pendulum's */
        avr_irq_register_notify(avr_get_interrupt_irq(avr, 1) + AVR_INT_IRQ_RUNNING, on_vector, (void *)1);
        avr_irq_register_notify(avr_get_interrupt_irq(avr, 2) + AVR_INT_IRQ_RUNNING, on_vector, (void *)1);
        avr_irq_register_notify(avr_get_interrupt_irq(avr, 5) + AVR_INT_IRQ_RUNNING, on_vector, (void *)0);
        avr_irq_t *pind = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), IOPORT_IRQ_REG_PIN);
        pind->flags &= ~IRQ_FLAG_FILTERED; /* every read, also of the value read last time */
        avr_irq_register_notify(pind, on_pind_read, NULL);
        state = run_twin((avr_cycle_count_t)llround(chunk_us * 1e-6 * avr->frequency));
    } else {
        if (spin_hz > 0) {
            spin_period = (avr_cycle_count_t)(avr->frequency / spin_hz);
            avr_cycle_timer_register(avr, spin_period / 5, spin, NULL);
        }
        while (!stop && state != cpu_Done && state != cpu_Crashed) {
            state = avr_run(avr);
            if (avr->cycle - last_write >= avr->frequency) {
                last_write = avr->cycle;
                write_stats();
            }
        }
    }
    write_stats();
    /* no uart_pty_stop(): it signals its thread with SIGINT, which this program catches; exit ends the thread */
    fprintf(stderr, "iwp_simavr: %llu control steps, %.0f cycles mean, %llu max; edges caught up %lld, %lld (%s)\n",
            (unsigned long long)steps, steps ? (double)total / (double)steps : 0.0, (unsigned long long)worst,
            caught_up[0], caught_up[1], state == cpu_Crashed ? "crashed" : "stopped");
    return state == cpu_Crashed;
}
