/*
 * sim_isr.h - whole-interrupt timing: cycles from the core's jump to a
 * vector to the end of the ISR's `reti`, for every vector, whatever the
 * firmware's probe pins say (they cannot see the prologue and epilogue the
 * compiler wraps around an ISR).  Watched instruction by instruction from
 * the PC and SP (simavr's RUNNING irqs did not pair up reliably).
 */
#ifndef SIM_ISR_H
#define SIM_ISR_H

#include <stdint.h>

#include "sim_avr.h"

typedef struct {
  uint64_t count, sum, max;
} sim_isr_stat_t;

/* Start watching every vector of avr (call once, after avr_init), then
 * sim_isr_step() after every instruction. */
void sim_isr_watch(avr_t *avr);
void sim_isr_step(void);

/* A conversion starts (ADSC written): note how long after the running
 * ISR's vector, per vector (the ADC's own chains conversions, the timer's
 * starts a scan).  The ADC waits for its next clock edge after ADSC, so
 * these delays decide how many ADC clocks each conversion really takes. */
void sim_isr_note_adsc(void);
uint64_t sim_isr_adsc_max(uint8_t vector);

/* What was seen of one vector (zeros if it never ran), or of all of them
 * together. */
sim_isr_stat_t sim_isr_stat(uint8_t vector);
sim_isr_stat_t sim_isr_all(void);

#endif /* SIM_ISR_H */
