/*
 * reply.h - the replies to command lines (docs/protocol.md): `ok ...`,
 * `error:<code> <command>: <what>; <allowed>`, `ok status ...` and
 * `ok help <command> <arguments>` (one line per command).  A producer:
 * the output scheduler (switchboard.c) sets the reply up and writes it one step of
 * at most UART_STEP_MAX characters at a time.
 */
#ifndef REPLY_H
#define REPLY_H

#include <stdint.h>

/* Codes of a reply: 0 is `ok`, 1..127 the `error:<code>` of command.h,
 * and the two multi-field replies. */
#define REPLY_OK 0
#define REPLY_STATUS 0xFE
#define REPLY_HELP 0xFF

/* What follows the reply's text: nothing, a decimal number, or a word
 * from flash (a vocab.h name). */
enum { REPLY_TAIL_NONE, REPLY_TAIL_NUM, REPLY_TAIL_WORD };

/* The next reply (texts and words in flash; text may be 0 for a bare
 * `ok`): `ok <text>` or `error:<code> <text>`, also REPLY_STATUS and
 * REPLY_HELP; `ok <text><n>`; `ok <text><word>`, word n of a word list. */
void reply_set_plain(uint8_t code, const char *text_P);
void reply_set(uint8_t code, const char *text_P, uint32_t n);
void reply_set_word(const char *text_P, const char *list_P, uint8_t n);

/* `error:<code> <command>: <what>; <allowed>` (docs/protocol.md).  The
 * command is command_word(id), or for id CMD_NONE (an unknown word, a
 * line too long or with bytes lost) the first word of the line `quote`,
 * copied (6 characters at most), and the texts follow from the code.
 * text_P: two words in flash, what is wrong and what is allowed
 * ("too long\0" "0..3600"); an empty second word (a text ending "\0")
 * lists the command's own arguments, as help shows them. */
void reply_set_error(uint8_t code, uint8_t id, const char *quote, const char *text_P);

/* ` <key>=<value>` (sep first) of setting k: run, mode, range, units (the
 * value `counts`, 0 phys), cfg, fs, interval, link; the first
 * SETTINGS_IN_HEADER are the report header's too.  At most 20 characters. */
#define SETTINGS_IN_HEADER 5
void reply_put_setting(uint8_t k, char sep, uint8_t counts);

/* One step of the reply: REPLY_MORE (call again with step + 1),
 * REPLY_LINE_DONE (a line of a multi-line reply is out: the next starts
 * at step 0; others may write between them), REPLY_DONE. */
#define REPLY_MORE 0
#define REPLY_LINE_DONE 1
#define REPLY_DONE 2
uint8_t reply_step(uint8_t step);

#endif /* REPLY_H */
