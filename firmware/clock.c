/* clock.c - see clock.h. */
#include "clock.h"

#include <avr/interrupt.h>
#include <avr/io.h>

void clock_init(void)
{
  TCCR0B = (1 << CS02) | (1 << CS00); /* F_CPU / 1024, normal mode */
  TIMSK0 = (1 << TOIE0);
}

uint8_t clock_now(void)
{
  return GPIOR1;
}

/* GPIOR1 += 1, saving the one register and SREG it needs: 9 instructions,
 * about 20 cycles every 26 ms, and no SRAM. */
ISR(TIMER0_OVF_vect, ISR_NAKED)
{
  __asm__ volatile("push r24\n\t"
                   "in r24, __SREG__\n\t"
                   "push r24\n\t"
                   "in r24, %0\n\t"
                   "inc r24\n\t"
                   "out %0, r24\n\t"
                   "pop r24\n\t"
                   "out __SREG__, r24\n\t"
                   "pop r24\n\t"
                   "reti" ::"I"(_SFR_IO_ADDR(GPIOR1)));
}
