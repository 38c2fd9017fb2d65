/* iwp_simavr.c: run iwp's AVR firmware under simavr, its serial port on a pseudo-terminal.
 *
 *     iwp_simavr FIRMWARE.elf [--stats FILE] [--spin HZ]
 *
 * Prints "port: /dev/pts/N" once the port is ready; the host then talks to it as to a board
 * (iwp rig run ... --port /dev/pts/N). The step marker D13 (PB5) is watched: the number of cycles between
 * its rising and falling edges is the control step's cost, in simavr's cycle count, written as JSON to
 * --stats every simulated second and at the end. --spin HZ turns the pendulum's encoder at HZ edges per
 * second (and the wheel's at 5 times that), so that the step and the encoder interrupts do real work.
 * SIGINT/SIGTERM stop it. Links against Debian's libsimavr-dev (simavr, simavrparts).
 */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "avr_ioport.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "uart_pty.h"

static avr_t *avr;
static uart_pty_t pty;
static volatile sig_atomic_t stop;
static avr_cycle_count_t started, steps, total, worst, last_write;
static const char *stats_path;
static avr_cycle_count_t spin_period;
static int spin_phase;
static avr_irq_t *pins_d;

static void on_signal(int s) { (void)s; stop = 1; }

static void write_stats(void)
{
    if (!stats_path) return;
    char tmp[512];
    snprintf(tmp, sizeof tmp, "%s.tmp", stats_path);
    FILE *f = fopen(tmp, "w");
    if (!f) return;
    fprintf(f, "{\"frequency\": %u, \"steps\": %llu, \"cycles_mean\": %.1f, \"cycles_max\": %llu, "
               "\"cycles\": %llu}\n",
            avr->frequency, (unsigned long long)steps, steps ? (double)total / (double)steps : 0.0,
            (unsigned long long)worst, (unsigned long long)avr->cycle);
    fclose(f);
    rename(tmp, stats_path);
}

static void marker(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)param;
    if (value) {
        started = avr->cycle;
    } else if (started) {
        avr_cycle_count_t c = avr->cycle - started;
        steps++;
        total += c;
        if (c > worst) worst = c;
        started = 0;
    }
}

/* quadrature: the pendulum's A/B on D2/D3 every spin_period cycles, the wheel's D4/D5 five times as often */
static avr_cycle_count_t spin(struct avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a; (void)param;
    static const uint8_t gray[4] = {0, 1, 3, 2};
    spin_phase++;
    uint8_t w = gray[spin_phase & 3];
    avr_raise_irq(pins_d + 4, w & 1);
    avr_raise_irq(pins_d + 5, (w >> 1) & 1);
    if (spin_phase % 5 == 0) {
        uint8_t p = gray[(spin_phase / 5) & 3];
        avr_raise_irq(pins_d + 2, p & 1);
        avr_raise_irq(pins_d + 3, (p >> 1) & 1);
    }
    return when + spin_period / 5;
}

int main(int argc, char **argv)
{
    const char *fw = NULL;
    double spin_hz = 0.0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--stats") && i + 1 < argc) stats_path = argv[++i];
        else if (!strcmp(argv[i], "--spin") && i + 1 < argc) spin_hz = atof(argv[++i]);
        else fw = argv[i];
    }
    if (!fw) {
        fprintf(stderr, "usage: %s FIRMWARE.elf [--stats FILE] [--spin HZ]\n", argv[0]);
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
    uart_pty_init(avr, &pty);
    uart_pty_connect(&pty, '0');
    printf("port: %s\n", pty.pty.slavename);
    fflush(stdout);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), 5), marker, NULL);
    pins_d = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), 0);
    if (spin_hz > 0) {
        spin_period = (avr_cycle_count_t)(avr->frequency / spin_hz);
        avr_cycle_timer_register(avr, spin_period / 5, spin, NULL);
    }
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    int state = cpu_Running;
    while (!stop && state != cpu_Done && state != cpu_Crashed) {
        state = avr_run(avr);
        if (avr->cycle - last_write >= avr->frequency) {
            last_write = avr->cycle;
            write_stats();
        }
    }
    write_stats();
    /* no uart_pty_stop(): it signals its thread with SIGINT, which this program catches; exit ends the thread */
    fprintf(stderr, "iwp_simavr: %llu control steps, %.0f cycles mean, %llu max (%s)\n", (unsigned long long)steps,
            steps ? (double)total / (double)steps : 0.0, (unsigned long long)worst,
            state == cpu_Crashed ? "crashed" : "stopped");
    return state == cpu_Crashed;
}
