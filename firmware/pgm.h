/*
 * pgm.h - constant strings and tables in flash on the AVR, plain memory on
 * the host, so pure modules build both ways.
 */
#ifndef PGM_H
#define PGM_H

#ifdef __AVR__
#  include <avr/pgmspace.h>
#else
#  include <string.h>
#  define PROGMEM
#  define PSTR(s) (s)
#  define pgm_read_byte(p) (*(const unsigned char *)(p))
#  define pgm_read_word(p) (*(p))
#  define pgm_read_dword(p) (*(p))
#  define pgm_read_ptr(p) (*(p))
#  define strcmp_P strcmp
#  define strcasecmp_P strcasecmp
#  include <strings.h>
#endif

#endif /* PGM_H */
