/* sim_isr.c - see sim_isr.h. */
#include "sim_isr.h"

#include "sim_interrupts.h"
#include "sim_irq.h"

#define SIM_ISR_VECTORS 64

static struct {
  avr_t *avr;
  avr_cycle_count_t entered[SIM_ISR_VECTORS];
  sim_isr_stat_t stat[SIM_ISR_VECTORS];
} isr;

/* simavr raises a vector's RUNNING irq to 1 as it jumps to the vector and
 * back to 0 when the ISR executes `reti`. */
static void running(avr_irq_t *irq, uint32_t value, void *param)
{
  uint8_t v = (uint8_t)(uintptr_t)param;
  (void)irq;
  if (value) {
    isr.entered[v] = isr.avr->cycle;
  } else if (isr.entered[v]) {
    uint64_t d = isr.avr->cycle - isr.entered[v];
    sim_isr_stat_t *s = &isr.stat[v];
    s->count++;
    s->sum += d;
    if (d > s->max)
      s->max = d;
  }
}

void sim_isr_watch(avr_t *avr)
{
  isr.avr = avr;
  for (unsigned v = 1; v < SIM_ISR_VECTORS; v++) {
    avr_irq_t *irq = avr_get_interrupt_irq(avr, (uint8_t)v);
    if (irq)
      avr_irq_register_notify(irq + AVR_INT_IRQ_RUNNING, running, (void *)(uintptr_t)v);
  }
}

sim_isr_stat_t sim_isr_stat(uint8_t vector)
{
  sim_isr_stat_t none = {0, 0, 0};
  return vector < SIM_ISR_VECTORS ? isr.stat[vector] : none;
}

sim_isr_stat_t sim_isr_all(void)
{
  sim_isr_stat_t all = {0, 0, 0};
  for (unsigned v = 0; v < SIM_ISR_VECTORS; v++) {
    all.count += isr.stat[v].count;
    all.sum += isr.stat[v].sum;
    if (isr.stat[v].max > all.max)
      all.max = isr.stat[v].max;
  }
  return all;
}
