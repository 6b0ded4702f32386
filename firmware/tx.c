/*
 * tx.c - the output scheduler (see tx.h).  A job is written line by line
 * and each line step by step; `job` and `step` remember where it stands.
 * The stream goes first: a frame may cut into a text line, a raw row or
 * count line only between two lines of the job.
 */
#include "tx.h"

#include "adc.h"
#include "command.h"
#include "console.h"
#include "proto.h"
#include "reply.h"
#include "report.h"
#include "stream.h"
#include "uart.h"

enum { JOB_NONE, JOB_BOOT, JOB_REPLY, JOB_REPORT, JOB_ECHO };

/* flags */
#define REPORT_NEXT 1 /* a report waits for the current job to end */
#define PAUSED      2 /* a report waits for the reply written between its lines */
#define HOLD_ROWS   4 /* a new run's rows wait for the reply that started it */
#define REPLY_NEXT  8 /* a reply waits for the echo of its command line */
#define ROW_GAP    16 /* ... and then for a row or frame, so that the two never
                       * hold the stream back together (link.h's budget) */

static struct {
  uint8_t job, step, flags;
} tx;

void tx_init(uint8_t reset_cause)
{
  report_init(reset_cause);
  proto_init(uart_write);
}

uint8_t tx_can_write(void)
{
  return uart_tx_room() >= UART_STEP_MAX;
}

uint8_t tx_busy(void)
{
  return tx.job != JOB_NONE || stream_busy();
}

/* 1 when the current job stands between two lines. */
static uint8_t at_line_boundary(void)
{
  return tx.job == JOB_NONE || tx.step == 0;
}

uint8_t tx_can_interject(void)
{
  return (tx.job == JOB_NONE || (tx.job == JOB_REPORT && tx.step == 0)) && !stream_line_open();
}

/* A new job.  A reply may come between two lines of a report: the report
 * pauses (its place is kept by report.c) and resumes after it. */
static void start(uint8_t job)
{
  if (tx.job == JOB_ECHO && job == JOB_REPLY) {
    tx.flags |= REPLY_NEXT;
    return;
  }
  if (tx.job == JOB_REPORT && job != JOB_REPORT)
    tx.flags |= PAUSED;
  tx.job = job;
  tx.step = 0;
}

void tx_boot(void)
{
  start(JOB_BOOT);
}

void tx_echo(void)
{
  start(JOB_ECHO);
}

void tx_report(void)
{
  if (tx.job != JOB_NONE || (tx.flags & PAUSED)) {
    tx.flags |= REPORT_NEXT;
    return;
  }
  report_begin();
  start(JOB_REPORT);
}

static void plain(uint8_t code, const char *text_P)
{
  reply_set_plain(code, text_P);
  start(JOB_REPLY);
}

void tx_ok(const char *text_P)
{
  plain(REPLY_OK, text_P);
}

__attribute__((noinline)) void tx_ok_n(const char *text_P, uint32_t n)
{
  reply_set(REPLY_OK, text_P, n);
  start(JOB_REPLY);
}

__attribute__((noinline)) void tx_ok_word(const char *text_P, const char *list_P, uint8_t n)
{
  reply_set_word(text_P, list_P, n);
  start(JOB_REPLY);
}

void tx_error(uint8_t code, uint8_t id, const char *text_P)
{
  reply_set_error(code, id, 0, text_P);
  start(JOB_REPLY);
}

void tx_refuse(uint8_t code, const char *line)
{
  reply_set_error(code, CMD_NONE, line, 0);
  start(JOB_REPLY);
}

void tx_status(void)
{
  plain(REPLY_STATUS, 0);
}

void tx_help(void)
{
  plain(REPLY_HELP, 0);
}

void tx_abort_report(void)
{
  if (tx.job == JOB_REPORT)
    tx.job = JOB_NONE;
  tx.flags &= (uint8_t)~(PAUSED | REPORT_NEXT);
}

void tx_new_run(void)
{
  tx_abort_report();
  report_new_run();
}

__attribute__((noinline)) void tx_restart_rows(void)
{
  stream_restart();
  tx.flags |= HOLD_ROWS; /* released when the next reply is written */
}

/* The current job has written its last line: a paused report resumes at
 * the line it had reached, from its start; a waiting one begins. */
static void job_done(void)
{
  if (tx.job == JOB_REPLY || tx.job == JOB_BOOT)
    tx.flags &= (uint8_t)~HOLD_ROWS;
  tx.job = JOB_NONE;
  if (tx.flags & REPLY_NEXT) {
    tx.flags &= (uint8_t)~REPLY_NEXT;
    if (stream_holds_oldest() && adc_running() && !(tx.flags & HOLD_ROWS))
      tx.flags |= ROW_GAP; /* rows keep coming: one goes first */
    tx.job = JOB_REPLY;
    tx.step = 0;
  } else if (tx.flags & PAUSED) {
    tx.flags &= (uint8_t)~PAUSED;
    tx.job = JOB_REPORT;
    tx.step = 0;
  } else if (tx.flags & REPORT_NEXT) {
    tx.flags &= (uint8_t)~REPORT_NEXT;
    tx_report();
  }
}

void tx_poll(void)
{
  while (tx_can_write()) {
    uint8_t done;
    if (stream_step(at_line_boundary(), tx.flags & HOLD_ROWS)) {
      tx.flags &= (uint8_t)~ROW_GAP;
      continue;
    }
    if ((tx.flags & ROW_GAP) && !adc_pending() && !adc_running())
      tx.flags &= (uint8_t)~ROW_GAP; /* sampling ended (start <count>, stop): no row will come */
    if (tx.job == JOB_NONE || (tx.flags & ROW_GAP))
      break;
    if (tx.job == JOB_REPORT) {
      uint8_t room = uart_tx_room();
      done = report_step(tx.step);
      if (done == REPORT_AGAIN)
        break; /* the engine's waiting work, a piece: the loop feeds it first */
      if (done == REPORT_MORE && uart_tx_room() == room) {
        tx.step++; /* a step that only computed (a T line's search): the loop */
        break;     /* feeds the engine before the next one */
      }
      tx.step = done == REPORT_MORE ? (uint8_t)(tx.step + 1) : 0;
      done = done == REPORT_DONE;
    } else if (tx.job == JOB_REPLY) {
      done = reply_step(tx.step); /* a line of help at a time: rows may come between */
      tx.step = done == REPLY_MORE ? (uint8_t)(tx.step + 1) : 0;
      done = done == REPLY_DONE;
    } else if (tx.job == JOB_ECHO) {
      done = console_echo_job();
    } else {
      done = report_boot_step(tx.step);
      tx.step++;
    }
    if (done)
      job_done();
  }
}
