/*
 * sim_adc.c - the ADC: row i of the input to the i-th conversion of each
 * mux channel 0..6 (from the file, again from its start in terminal mode,
 * or from the synthetic IMU), delivered exactly whatever the reference.
 */
#include "sim_adc.h"

#include <string.h>

#include "sim_regbit.h"

#include "sim_fault.h"
#include "sim_msg.h"

uint64_t adc_rows_consumed(const harness_t *h)
{
  return h->conv[ROW_COLUMNS - 1] < h->nrows ? h->conv[ROW_COLUMNS - 1] :
                                               h->nrows;
}

/* The next input row: from the file, or (terminal mode) from the file
 * again from its start once it ends, or from the synthetic IMU. */
static int next_row(harness_t *h, uint16_t code[ROW_COLUMNS], char *err,
                    size_t errlen)
{
  if (h->synthetic) {
    synth_next(&h->synth, code);
    return 1;
  }
  int got = rows_next(&h->rows, code, err, errlen);
  if (got == 0 && h->pty) {
    if (rows_rewind(&h->rows, err, errlen))
      return -1;
    h->file_loops++;
    got = rows_next(&h->rows, code, err, errlen);
  }
  return got;
}

static uint16_t serve(harness_t *h, int ch)
{
  uint64_t k = h->conv[ch]++;

  if (k >= h->nrows) {
    h->extra_conv++;
    if (ch == ROW_COLUMNS - 1)
      h->extra_scans++;
    return h->win[(h->nrows - 1) % ROW_WIN][ch];
  }
  if (h->state < ST_START || (h->state == ST_START && h->txq_len))
    h->stray_conv++;
  if (!h->order_warned &&
      ((ch > 0 && h->conv[ch - 1] <= k) ||
       (ch == 0 && k > 0 && h->conv[ROW_COLUMNS - 1] < k))) {
    h->order_warned = 1;
    warn("t=%.6f s: conversion %llu of mux %d is out of scan order "
         "(mux 0..6 expected in turn); rows may be misaligned",
         sim_time(h), (unsigned long long)k, ch);
  }
  while (h->loaded <= k) {
    uint64_t lag = k;
    int lagger = ch;
    for (int c = 0; c < ROW_COLUMNS; c++)
      if (c != ch && h->conv[c] < lag) {
        lag = h->conv[c];
        lagger = c;
      }
    if (h->loaded >= lag + ROW_WIN) {
      fail(h, EXIT_FAIL,
           "t=%.6f s: mux %d ran %d conversions ahead of mux %d; "
           "imu-sim serves row i to the i-th conversion of each channel",
           sim_time(h), ch, ROW_WIN, lagger);
      return NEUTRAL_CODE;
    }
    char err[256];
    int got = next_row(h, h->win[h->loaded % ROW_WIN], err, sizeof err);
    if (got <= 0) {
      fail(h, EXIT_INPUT, "%s",
           got < 0 ? err : "ADC file changed while running");
      return NEUTRAL_CODE;
    }
    h->loaded++;
  }
  return fault_adc(h, ch, k, h->win[k % ROW_WIN][ch]);
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
static uint32_t code_to_mv(harness_t *h, uint16_t code)
{
  avr_t *avr = h->avr;
  uint8_t refi =
      avr_regbit_get_array(avr, h->adc->ref, ARRAY_SIZE(h->adc->ref));
  uint16_t ref = h->adc->ref_values[refi];
  uint32_t vref;
  switch (ref) {
  case ADC_VREF_AVCC: vref = avr->avcc; break;
  case ADC_VREF_AREF: vref = avr->aref; break;
  case ADC_VREF_VCC: vref = avr->vcc ? avr->vcc : 3300; break;
  default: vref = ref; break;
  }
  if (ref != ADC_VREF_AVCC && !h->ref_warned) {
    h->ref_warned = 1;
    warn("t=%.6f s: the firmware converts against %s (board.h: AVCC); "
         "codes are delivered exactly anyway",
         sim_time(h), ref_name(ref));
  }
  return ((uint32_t)code * vref + 1022) / 1023;
}

static void adc_trigger(avr_irq_t *irq, uint32_t value, void *param)
{
  union {
    avr_adc_mux_t mux;
    uint32_t v;
  } e = { .v = value };
  harness_t *h = param;
  avr_t *avr = h->avr;
  avr_adc_t *p = h->adc;
  uint16_t code;
  int ch = -1;
  (void)irq;
  sim_isr_note_adsc();

  /* The hardware keeps the last result until the next one completes;
   * simavr computes it when ADCL is read.  Latch a result the firmware
   * has not read yet before the new values go in. */
  if (p->read_status == 0) {
    uint16_t reg =
        (uint16_t)(h->last_code << (avr_regbit_get(avr, p->adlar) ? 6 : 0));
    avr->data[p->r_adcl] = (uint8_t)reg;
    avr->data[p->r_adch] = (uint8_t)(reg >> 8);
    p->read_status = 1;
  }

  if (e.mux.kind == ADC_MUX_SINGLE && e.mux.src < ROW_COLUMNS)
    ch = e.mux.src;
  if (ch < 0) {
    h->other_conv++;
    if (!h->mux_warned) {
      h->mux_warned = 1;
      warn("t=%.6f s: the firmware converts mux kind %u source %u, not an "
           "IMU column (mux 0..6); it reads 0",
           sim_time(h), (unsigned)e.mux.kind, (unsigned)e.mux.src);
    }
    code = 0;
  } else if (!h->armed || !avr_regbit_get(avr, p->adc.enable)) {
    /* Before the harness arms, or a conversion started with the ADC
     * interrupt off: not a scan's (the firmware's start-up conversion,
     * the 25-clock first one after ADEN, is polled and thrown away). */
    h->neutral_conv++;
    code = NEUTRAL_CODE;
  } else {
    code = serve(h, ch);
  }

  /* All eight inputs carry the value: the firmware may switch ADMUX to the
   * next channel before it reads this result, and simavr would then read
   * that channel's input. */
  uint32_t mv = code_to_mv(h, code);
  if (ch >= 0)
    avr_raise_irq(h->adc_irq + ADC_IRQ_ADC0 + ch, mv);
  for (int i = 0; i < 8; i++)
    if (i != ch)
      avr_raise_irq(h->adc_irq + ADC_IRQ_ADC0 + i, mv);
  h->last_code = code;

  if (ch == ROW_COLUMNS - 1 && h->armed)
    if (h->on_scan)
      h->on_scan(h);
}

void adc_connect(harness_t *h)
{
  avr_irq_register_notify(h->adc_irq + ADC_IRQ_OUT_TRIGGER, adc_trigger, h);
}
