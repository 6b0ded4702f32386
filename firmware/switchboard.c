/*
 * switchboard.c - the output scheduler (see switchboard.h).  A job is written line by line
 * and each line step by step; `job` and `step` remember where it stands.
 * The stream goes first: a frame may cut into a text line, a raw row or
 * count line only between two lines of the job.
 */
#include "switchboard.h"

#include "adc.h"
#include "board.h"
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
#define PAUSED 2      /* a report waits for the reply written between its lines */
#define HOLD_ROWS 4   /* a new run's rows wait for the reply that started it */
#define REPLY_NEXT 8  /* a reply waits for the echo of its command line */
#define ROW_GAP                                                                                              \
  16 /* ... and then for a row or frame, so that the two never
                       * hold the stream back together (link.h's budget) */

static struct {
  uint8_t job, flags;
} out;
#define out_step BOARD_SPARE_REG /* the step within the job's line (board.h) */

void switchboard_init(void)
{
  report_init();
  proto_init(uart_write);
}

uint8_t switchboard_can_write(void)
{
  return uart_tx_room() >= UART_STEP_MAX;
}

uint8_t switchboard_busy(void)
{
  return out.job != JOB_NONE || stream_busy();
}

/* 1 when the current job stands between two lines. */
static uint8_t at_line_boundary(void)
{
  return out.job == JOB_NONE || out_step == 0;
}

uint8_t switchboard_can_interject(void)
{
  return (out.job == JOB_NONE || (out.job == JOB_REPORT && out_step == 0)) && !stream_line_open();
}

/* A new job.  A reply may come between two lines of a report: the report
 * pauses (its place is kept by report.c) and resumes after it. */
static void start(uint8_t job)
{
  if (out.job == JOB_ECHO && job == JOB_REPLY) {
    out.flags |= REPLY_NEXT;
    return;
  }
  if (out.job == JOB_REPORT && job != JOB_REPORT)
    out.flags |= PAUSED;
  out.job = job;
  out_step = 0;
}

void switchboard_boot(void)
{
  start(JOB_BOOT);
}

void switchboard_echo(void)
{
  start(JOB_ECHO);
}

void switchboard_report(void)
{
  if (out.job != JOB_NONE || (out.flags & PAUSED)) {
    out.flags |= REPORT_NEXT;
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

void switchboard_ok(const char *text_P)
{
  plain(REPLY_OK, text_P);
}

__attribute__((noinline)) void switchboard_ok_n(const char *text_P, uint32_t n)
{
  reply_set(REPLY_OK, text_P, n);
  start(JOB_REPLY);
}

__attribute__((noinline)) void switchboard_ok_word(const char *text_P, const char *list_P, uint8_t n)
{
  reply_set_word(text_P, list_P, n);
  start(JOB_REPLY);
}

void switchboard_error(uint8_t code, uint8_t id, const char *text_P)
{
  reply_set_error(code, id, 0, text_P);
  start(JOB_REPLY);
}

void switchboard_refuse(uint8_t code, const char *line)
{
  reply_set_error(code, CMD_NONE, line, 0);
  start(JOB_REPLY);
}

void switchboard_status(void)
{
  plain(REPLY_STATUS, 0);
}

void switchboard_help(void)
{
  plain(REPLY_HELP, 0);
}

void switchboard_abort_report(void)
{
  if (out.job == JOB_REPORT)
    out.job = JOB_NONE;
  out.flags &= (uint8_t) ~(PAUSED | REPORT_NEXT);
}

void switchboard_new_run(void)
{
  switchboard_abort_report();
  report_new_run();
}

__attribute__((noinline)) void switchboard_restart_rows(void)
{
  stream_restart();
  out.flags |= HOLD_ROWS; /* released when the next reply is written */
}

/* The current job has written its last line: a paused report resumes at
 * the line it had reached, from its start; a waiting one begins. */
static void job_done(void)
{
  if (out.job == JOB_REPLY || out.job == JOB_BOOT)
    out.flags &= (uint8_t)~HOLD_ROWS;
  out.job = JOB_NONE;
  if (out.flags & REPLY_NEXT) {
    out.flags &= (uint8_t)~REPLY_NEXT;
    if (stream_holds_oldest() && adc_running() && !(out.flags & HOLD_ROWS))
      out.flags |= ROW_GAP; /* rows keep coming: one goes first */
    out.job = JOB_REPLY;
    out_step = 0;
  } else if (out.flags & PAUSED) {
    out.flags &= (uint8_t)~PAUSED;
    out.job = JOB_REPORT;
    out_step = 0;
  } else if (out.flags & REPORT_NEXT) {
    out.flags &= (uint8_t)~REPORT_NEXT;
    switchboard_report();
  }
}

void switchboard_poll(void)
{
  while (switchboard_can_write()) {
    uint8_t done;
    if (stream_step(at_line_boundary(), out.flags & HOLD_ROWS)) {
      out.flags &= (uint8_t)~ROW_GAP;
      continue;
    }
    if ((out.flags & ROW_GAP) && !adc_pending() && !adc_running())
      out.flags &= (uint8_t)~ROW_GAP; /* sampling ended (start <count>, stop): no row will come */
    if (out.job == JOB_NONE || (out.flags & ROW_GAP))
      break;
    if (out.job == JOB_REPORT) {
      uint8_t room = uart_tx_room();
      done = report_step(out_step);
      if (done == REPORT_MORE && uart_tx_room() == room) {
        out_step++; /* a step that only computed (a T line's search): the loop */
        break;      /* feeds the engine before the next one */
      }
      out_step = done == REPORT_MORE ? (uint8_t)(out_step + 1) : 0;
      done = done == REPORT_DONE;
    } else if (out.job == JOB_REPLY) {
      done = reply_step(out_step); /* a line of help at a time: rows may come between */
      out_step = done == REPLY_MORE ? (uint8_t)(out_step + 1) : 0;
      done = done == REPLY_DONE;
    } else if (out.job == JOB_ECHO) {
      done = console_echo_job();
    } else {
      done = report_boot_step(out_step);
      out_step++;
    }
    if (done)
      job_done();
  }
}
