/*
 * sim_fault.h - the faults a real board meets, injected on request (imu-sim
 * options, see --help): a noisy link (bytes lost, bits flipped, both ways,
 * seeded), a UART without flow control (the chip's two-frame receive buffer
 * and its data overrun), EEPROM bytes flipped at a given time, power cuts
 * and brown-outs (at a time, in a report, in a `save`), a stuck or railed
 * ADC channel.  What was injected is counted for --stats.
 */
#ifndef SIM_FAULT_H
#define SIM_FAULT_H

#include <stdint.h>

#include "sim_avr.h"

struct harness;

#define FAULT_EE_MAX 8

enum { POWER_NONE, POWER_CUT, POWER_BROWNOUT };
enum { WHEN_TIME, WHEN_REPORT, WHEN_SAVE };
enum { ADC_FAULT_NONE, ADC_FAULT_CODE, ADC_FAULT_STUCK };

typedef struct {
  /* options */
  double loss, flip; /* per byte on the link, each way */
  uint64_t rng;      /* xorshift state (--fault-seed) */
  int no_flow;       /* --no-flow-control */
  double overrun;    /* --uart-overrun: per host byte */
  double frame;      /* --uart-frame-error: per host byte */
  int adc_kind, adc_ch;
  uint16_t adc_code;
  uint64_t adc_row;
  struct {
    double t;
    uint16_t addr;
    uint8_t mask;
    int done;
  } ee[FAULT_EE_MAX];
  int nee;
  int power, power_when;
  double power_t;
  /* state */
  int link_on; /* the link is noisy now (set by the runner) */
  int power_done, power_due, prev_dollar, dor_pending;
  uint16_t stuck_code;
  avr_cycle_count_t next_at; /* when fault_poll() has work; ~0: never */
  /* what happened */
  uint64_t in_lost, in_flipped, in_frame_errors, in_data_flips, out_lost,
      out_flipped;
  uint64_t overruns, overruns_injected, dor_events, ee_flipped, resets,
      adc_faulted;
} fault_t;

/* Options (from sim_cli.c); each returns 0, or dies with a message. */
void fault_parse_adc(fault_t *f, const char *arg);    /* CH=CODE|stuck[@ROW] */
void fault_parse_eeprom(fault_t *f, const char *arg); /* ADDR[:MASK]@SEC */
void fault_parse_power(fault_t *f, int kind,
                       const char *arg); /* SEC|report|save */
int fault_any(const fault_t *f);

void fault_connect(struct harness *h); /* after the MCU is made */
/* A host byte about to reach the UART: 0 lost on the line, else 1 with
 * *c as it arrives and *fe set when its stop bit was hit. */
int fault_host_byte(struct harness *h, uint8_t *c, int *fe);
/* After a host byte reached simavr's FIFO: a pending overrun's DOR. */
void fault_host_byte_delivered(struct harness *h);
/* The chip's receive buffer is full (two frames and one in the shift
 * register): a frame arriving now is lost with DOR set. */
int fault_rx_full(struct harness *h);
/* A device byte on its way to the host: 0 lost, else 1 with *c as received. */
int fault_device_byte(struct harness *h, uint8_t *c);
/* The code conversion ROW of channel CH reads. */
uint16_t fault_adc(struct harness *h, int ch, uint64_t row, uint16_t code);
/* Due work (EEPROM flips, a power event): from the run loop, when
 * avr->cycle >= next_at.  1 if the MCU was reset. */
int fault_poll(struct harness *h);

#endif /* SIM_FAULT_H */
