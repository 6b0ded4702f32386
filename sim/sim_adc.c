/*
 * sim_adc.c - the ADC: row i of the input to the i-th conversion of each
 * mux channel 0..6 (from the file, again from its start in terminal mode,
 * or from the synthetic IMU), delivered exactly whatever the reference.
 */
#include "harness.h"

#include <string.h>

#include "sim_regbit.h"


static void fatal_rows(const char *err)
{
  fail(EXIT_INPUT, "%s", err);
}

/* The next input row: from the file, or (terminal mode) from the file
 * again from its start once it ends, or from the synthetic IMU. */
static int next_row(uint16_t code[ROW_COLUMNS], char *err, size_t errlen)
{
  if (g.synthetic) {
    synth_next(&g.synth, code);
    return 1;
  }
  int got = rows_next(&g.rows, code, err, errlen);
  if (got == 0 && g.pty) {
    if (rows_rewind(&g.rows, err, errlen))
      return -1;
    g.file_loops++;
    got = rows_next(&g.rows, code, err, errlen);
  }
  return got;
}

static uint16_t serve(int ch)
{
  uint64_t k = g.conv[ch]++;

  if (k >= g.nrows) {
    g.extra_conv++;
    if (ch == ROW_COLUMNS - 1)
      g.extra_scans++;
    return g.win[(g.nrows - 1) % ROW_WIN][ch];
  }
  if (g.state < ST_START || (g.state == ST_START && g.txq_len))
    g.stray_conv++;
  if (!g.order_warned &&
      ((ch > 0 && g.conv[ch - 1] <= k) ||
       (ch == 0 && k > 0 && g.conv[ROW_COLUMNS - 1] < k))) {
    g.order_warned = 1;
    warn("t=%.6f s: conversion %llu of mux %d is out of scan order "
         "(mux 0..6 expected in turn); rows may be misaligned",
         sim_time(), (unsigned long long)k, ch);
  }
  while (g.loaded <= k) {
    uint64_t lag = k;
    int lagger = ch;
    for (int c = 0; c < ROW_COLUMNS; c++)
      if (c != ch && g.conv[c] < lag) {
        lag = g.conv[c];
        lagger = c;
      }
    if (g.loaded >= lag + ROW_WIN) {
      fail(EXIT_FAIL, "t=%.6f s: mux %d ran %d conversions ahead of mux %d; "
           "imu-sim serves row i to the i-th conversion of each channel",
           sim_time(), ch, ROW_WIN, lagger);
      return NEUTRAL_CODE;
    }
    char err[256];
    int got = next_row(g.win[g.loaded % ROW_WIN], err, sizeof err);
    if (got <= 0) {
      fatal_rows(got < 0 ? err : "ADC file changed while running");
      return NEUTRAL_CODE;
    }
    g.loaded++;
  }
  return g.win[k % ROW_WIN][ch];
}

static void row_consumed(void)
{
  uint64_t n = rows_consumed();
  if (g.state == ST_RUN) {
    g.deadline = g.avr->cycle + g.timeout_cycles;
    release_uart_in();
  }
  if (n == g.nrows && !g.rows_done) {
    g.rows_done = 1;
    if (g.state == ST_RUN)
      finish_run();
  }
}

static const char *ref_name(uint16_t ref)
{
  switch (ref) {
  case ADC_VREF_AREF: return "AREF";
  case ADC_VREF_VCC: return "VCC";
  case ADC_VREF_AVCC: return "AVCC";
  case ADC_VREF_V110: return "internal 1.1 V";
  case ADC_VREF_V256: return "internal 2.56 V";
  default: return "?";
  }
}

/* simavr converts at ADCL read time: code = mV * 1023 / Vref, with mux and
 * Vref of that moment.  AVCC and AREF are set to 1023 "mV", so mV == code;
 * an internal reference gets mV rounded up so that the code is exact too. */
static uint32_t code_to_mv(uint16_t code)
{
  avr_t *avr = g.avr;
  uint8_t refi = avr_regbit_get_array(avr, g.adc->ref, ARRAY_SIZE(g.adc->ref));
  uint16_t ref = g.adc->ref_values[refi];
  uint32_t vref;
  switch (ref) {
  case ADC_VREF_AVCC: vref = avr->avcc; break;
  case ADC_VREF_AREF: vref = avr->aref; break;
  case ADC_VREF_VCC: vref = avr->vcc ? avr->vcc : 3300; break;
  default: vref = ref; break;
  }
  if (ref != ADC_VREF_AVCC && !g.ref_warned) {
    g.ref_warned = 1;
    warn("t=%.6f s: the firmware converts against %s (board.h: AVCC); "
         "codes are delivered exactly anyway", sim_time(), ref_name(ref));
  }
  return ((uint32_t)code * vref + 1022) / 1023;
}

static void adc_trigger(avr_irq_t *irq, uint32_t value, void *param)
{
  union { avr_adc_mux_t mux; uint32_t v; } e = { .v = value };
  avr_t *avr = g.avr;
  avr_adc_t *p = g.adc;
  uint16_t code;
  int ch = -1;
  (void)irq; (void)param;
  sim_isr_note_adsc();

  /* The hardware keeps the last result until the next one completes;
   * simavr computes it when ADCL is read.  Latch a result the firmware
   * has not read yet before the new values go in. */
  if (p->read_status == 0) {
    uint16_t reg = (uint16_t)(g.last_code << (avr_regbit_get(avr, p->adlar) ? 6 : 0));
    avr->data[p->r_adcl] = (uint8_t)reg;
    avr->data[p->r_adch] = (uint8_t)(reg >> 8);
    p->read_status = 1;
  }

  if (e.mux.kind == ADC_MUX_SINGLE && e.mux.src < ROW_COLUMNS)
    ch = e.mux.src;
  if (ch < 0) {
    g.other_conv++;
    if (!g.mux_warned) {
      g.mux_warned = 1;
      warn("t=%.6f s: the firmware converts mux kind %u source %u, not an "
           "IMU column (mux 0..6); it reads 0", sim_time(),
           (unsigned)e.mux.kind, (unsigned)e.mux.src);
    }
    code = 0;
  } else if (!g.armed || !avr_regbit_get(avr, p->adc.enable)) {
    /* Before the harness arms, or a conversion started with the ADC
     * interrupt off: not a scan's (the firmware's start-up conversion,
     * the 25-clock first one after ADEN, is polled and thrown away). */
    g.neutral_conv++;
    code = NEUTRAL_CODE;
  } else {
    code = serve(ch);
  }

  /* All eight inputs carry the value: the firmware may switch ADMUX to the
   * next channel before it reads this result, and simavr would then read
   * that channel's input. */
  uint32_t mv = code_to_mv(code);
  if (ch >= 0)
    avr_raise_irq(g.adc_irq + ADC_IRQ_ADC0 + ch, mv);
  for (int i = 0; i < 8; i++)
    if (i != ch)
      avr_raise_irq(g.adc_irq + ADC_IRQ_ADC0 + i, mv);
  g.last_code = code;

  if (ch == ROW_COLUMNS - 1 && g.armed)
    row_consumed();
}

void adc_connect(void)
{
  avr_irq_register_notify(g.adc_irq + ADC_IRQ_OUT_TRIGGER, adc_trigger, NULL);
}
