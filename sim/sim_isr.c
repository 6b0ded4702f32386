/* sim_isr.c - see sim_isr.h. */
#include "sim_isr.h"

#include "sim_core.h"
#include "sim_interrupts.h"

#define SIM_ISR_VECTORS 64

static struct {
  avr_t *avr;
  uint32_t table_end; /* bytes: the vector table ends here */
  int cur;            /* vector running, -1: none */
  uint16_t sp0;       /* SP at its first instruction (PC pushed) */
  avr_cycle_count_t t0;
  sim_isr_stat_t stat[SIM_ISR_VECTORS];
  uint64_t adsc_max[SIM_ISR_VECTORS];
} isr = { .cur = -1 };

static uint16_t sp(void)
{
  return (uint16_t)(isr.avr->data[R_SPL] | isr.avr->data[R_SPH] << 8);
}

void sim_isr_watch(avr_t *avr)
{
  avr_int_table_p t = &avr->interrupts;
  unsigned last = 0;
  isr.avr = avr;
  for (unsigned i = 0; i < t->vector_count; i++)
    if (t->vector[i]->vector > last)
      last = t->vector[i]->vector;
  isr.table_end = (last + 1u) * avr->vector_size;
}

/* After every instruction: the PC only ever reaches the vector table when
 * the core takes an interrupt (it pushed the PC: SP is sp0); the ISR is over
 * when that PC is popped again (`reti`).  The firmware does not nest ISRs. */
void sim_isr_step(void)
{
  avr_t *avr = isr.avr;
  if (!avr)
    return;
  if (isr.cur < 0) {
    if (avr->pc && avr->pc < isr.table_end && avr->pc % avr->vector_size == 0) {
      isr.cur = (int)(avr->pc / avr->vector_size);
      isr.sp0 = sp();
      isr.t0 = avr->cycle;
    }
  } else if (sp() > isr.sp0) {
    uint64_t d = avr->cycle - isr.t0;
    sim_isr_stat_t *s = &isr.stat[isr.cur % SIM_ISR_VECTORS];
    s->count++;
    s->sum += d;
    if (d > s->max)
      s->max = d;
    isr.cur = -1;
  }
}

void sim_isr_note_adsc(void)
{
  if (isr.cur < 0)
    return; /* started from the main loop */
  uint64_t d = isr.avr->cycle - isr.t0;
  if (d > isr.adsc_max[isr.cur % SIM_ISR_VECTORS])
    isr.adsc_max[isr.cur % SIM_ISR_VECTORS] = d;
}

uint64_t sim_isr_adsc_max(uint8_t vector)
{
  return vector < SIM_ISR_VECTORS ? isr.adsc_max[vector] : 0;
}

sim_isr_stat_t sim_isr_stat(uint8_t vector)
{
  sim_isr_stat_t none = { 0, 0, 0 };
  return vector < SIM_ISR_VECTORS ? isr.stat[vector] : none;
}

sim_isr_stat_t sim_isr_all(void)
{
  sim_isr_stat_t all = { 0, 0, 0 };
  for (unsigned v = 0; v < SIM_ISR_VECTORS; v++) {
    all.count += isr.stat[v].count;
    all.sum += isr.stat[v].sum;
    if (isr.stat[v].max > all.max)
      all.max = isr.stat[v].max;
  }
  return all;
}
