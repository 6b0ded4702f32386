/* clock.c - see clock.h. */
#include "clock.h"

#include <avr/interrupt.h>
#include <avr/io.h>

void clock_init(void)
{
  TCCR0B = (1 << CS02) | (1 << CS00); /* F_CPU / 1024, normal mode */
  TIMSK0 = (1 << TOIE0);
}

uint8_t clock_ticks(void)
{
  return GPIOR1;
}

void clock_restart(void)
{
  GPIOR1 = 0;
}

/* GPIOR1 += 1 unless at 255, saving the one register and SREG it needs:
 * 10 instructions, about 20 cycles every 26 ms, and no SRAM. */
ISR(TIMER0_OVF_vect, ISR_NAKED)
{
  __asm__ volatile("push r24\n\t"
                   "in r24, __SREG__\n\t"
                   "push r24\n\t"
                   "in r24, %0\n\t"
                   "inc r24\n\t"
                   "breq 1f\n\t"
                   "out %0, r24\n"
                   "1:\n\t"
                   "pop r24\n\t"
                   "out __SREG__, r24\n\t"
                   "pop r24\n\t"
                   "reti" ::"I"(_SFR_IO_ADDR(GPIOR1)));
}
