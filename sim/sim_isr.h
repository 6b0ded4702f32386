/*
 * sim_isr.h - whole-interrupt timing from simavr's own interrupt status:
 * cycles from the moment the core enters a vector to its `reti`, for every
 * vector, whatever the firmware's probe pins say (they cannot see the
 * prologue and epilogue the compiler wraps around an ISR).
 */
#ifndef SIM_ISR_H
#define SIM_ISR_H

#include <stdint.h>

#include "sim_avr.h"

typedef struct {
  uint64_t count, sum, max;
} sim_isr_stat_t;

/* Start watching every vector of avr (call once, after avr_init). */
void sim_isr_watch(avr_t *avr);

/* What was seen of one vector (zeros if it never ran), or of all of them
 * together. */
sim_isr_stat_t sim_isr_stat(uint8_t vector);
sim_isr_stat_t sim_isr_all(void);

#endif /* SIM_ISR_H */
