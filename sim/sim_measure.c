/*
 * sim_measure.c - what imu-sim measures: CPU cycles while PB0/PB1/PB2 are
 * high (the firmware marks a sample set, the ADC interrupt, the engine),
 * idle cycles, the stack (painted SRAM and the lowest stack pointer), and
 * the figures of --stats / --stats-json.
 */
#include "sim_measure.h"

#include <errno.h>
#include <fcntl.h>
#include <gelf.h>
#include <libelf.h>
#include <string.h>
#include <unistd.h>

#include "sim_io.h"
#include "avr_ioport.h"
#include "avr_timer.h"

#include "sim_adc.h"
#include "sim_msg.h"

static void pulse(const harness_t *h, pulse_t *p, uint32_t value)
{
  int lvl = value & 1;
  if (lvl == p->level)
    return;
  p->level = lvl;
  if (lvl) {
    p->rise = h->avr->cycle;
    p->seen_rise = 1;
  } else if (p->seen_rise) {
    uint64_t d = h->avr->cycle - p->rise;
    p->count++;
    p->sum += d;
    if (d > p->max)
      p->max = d;
  }
}

static void pb0_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  harness_t *h = param;
  (void)irq;
  pulse(h, &h->pb0, value);
}

static void pb1_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  harness_t *h = param;
  (void)irq;
  pulse(h, &h->pb1, value);
}

static void pb2_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  harness_t *h = param;
  (void)irq;
  pulse(h, &h->pb2, value);
}

/* The state no_sleep() counts into (simavr's sleep hook carries no
 * pointer). */
static harness_t *sleep_h;

/* Fast: never wait for the wall clock, just count the idle cycles. */
static void no_sleep(avr_t *avr, avr_cycle_count_t how_long)
{
  (void)avr;
  sleep_h->slept += how_long + 1; /* the core then adds 1 + how_long cycles */
}

/* 1 if PATH is an AVR ELF executable. */
int elf_is_avr(const char *path)
{
  int fd = open(path, O_RDONLY), ok = 0;
  if (fd < 0 || elf_version(EV_CURRENT) == EV_NONE) {
    if (fd >= 0)
      close(fd);
    return 0;
  }
  Elf *e = elf_begin(fd, ELF_C_READ, NULL);
  GElf_Ehdr eh;
  if (e && elf_kind(e) == ELF_K_ELF && gelf_getehdr(e, &eh))
    ok = eh.e_machine == EM_AVR;
  if (e)
    elf_end(e);
  close(fd);
  return ok;
}

/* End of .bss (start of the heap) from the ELF symbol table, or 0. */
uint16_t elf_bss_end(const char *path)
{
  static const char *const names[] = { "__heap_start", "_end", "__bss_end" };
  uint32_t found[3] = { 0, 0, 0 };
  int fd = open(path, O_RDONLY);
  if (fd < 0 || elf_version(EV_CURRENT) == EV_NONE) {
    if (fd >= 0)
      close(fd);
    return 0;
  }
  Elf *e = elf_begin(fd, ELF_C_READ, NULL);
  Elf_Scn *scn = NULL;
  while (e && (scn = elf_nextscn(e, scn))) {
    GElf_Shdr sh;
    if (!gelf_getshdr(scn, &sh) || sh.sh_type != SHT_SYMTAB || !sh.sh_entsize)
      continue;
    Elf_Data *d = elf_getdata(scn, NULL);
    size_t n = sh.sh_size / sh.sh_entsize;
    for (size_t i = 0; d && i < n; i++) {
      GElf_Sym s;
      if (!gelf_getsym(d, (int)i, &s))
        continue;
      const char *nm = elf_strptr(e, sh.sh_link, s.st_name);
      for (int k = 0; nm && k < 3; k++)
        if (!strcmp(nm, names[k]))
          found[k] = (uint32_t)s.st_value | 0x80000000u;
    }
  }
  if (e)
    elf_end(e);
  close(fd);
  for (int k = 0; k < 3; k++)
    if (found[k])
      return (uint16_t)(found[k] & 0xFFFF);
  return 0;
}

typedef struct {
  int have_stack;
  unsigned stack_used, stack_free, lowest;
} stack_t_;

static stack_t_ stack_mark(const harness_t *h)
{
  stack_t_ s = { 0, 0, 0, 0 };
  avr_t *avr = h->avr;
  if (!avr->data || !h->bss_end || h->bss_end > avr->ramend)
    return s;
  unsigned a = h->bss_end;
  while (a <= avr->ramend && avr->data[a] == PAINT)
    a++;
  s.have_stack = 1;
  s.lowest = a;
  s.stack_used = avr->ramend + 1 - a;
  s.stack_free = a - h->bss_end;
  return s;
}

/* Mean and max of a pulse's cycles, "null" when it never pulsed. */
static void mean_max(const pulse_t *p, char mean[32], char max[32])
{
  if (!p->count) {
    strcpy(mean, "null");
    strcpy(max, "null");
    return;
  }
  snprintf(mean, 32, "%.1f", (double)p->sum / p->count);
  snprintf(max, 32, "%llu", (unsigned long long)p->max);
}

typedef struct {
  const char *key;
  char val[40];
  int text;
} stat_kv_t;

/* One "key value" a line, or a JSON object (closing F if it is a file). */
static void write_stats(const harness_t *h, FILE *f, const stat_kv_t *kv, int n,
                        int json)
{
  for (int i = 0; i < n; i++) {
    if (!json)
      fprintf(f, "%s %s\n", kv[i].key, kv[i].val);
    else
      fprintf(f, "%s  \"%s\": %s%s%s", i ? ",\n" : "{\n", kv[i].key,
              kv[i].text ? "\"" : "", kv[i].val, kv[i].text ? "\"" : "");
  }
  if (json)
    fputs("\n}\n", f);
  if (json && fclose(f))
    warn("%s: %s", h->stats_json, strerror(errno));
}

void print_stats(harness_t *h, int json)
{
  avr_t *avr = h->avr;
  stack_t_ st = stack_mark(h);
  double sim_s = sim_time(h);
  double busy = avr->cycle ? 1.0 - (double)h->slept / (double)avr->cycle : 0.0;
  FILE *f = stderr;
  char smean[32], smax[32], imean[32], imax[32], amean[32], amax[32];
  char dn[32] = "null", dd[32] = "null";
  char sused[32] = "null", sfree[32] = "null", bss[32] = "null";

  mean_max(&h->pb0, smean, smax);
  mean_max(&h->pb1, imean, imax);
  mean_max(&h->pb2, amean, amax);
  if (h->dev_n >= 0)
    snprintf(dn, sizeof dn, "%lld", h->dev_n);
  if (h->dev_drops >= 0)
    snprintf(dd, sizeof dd, "%lld", h->dev_drops);
  if (st.have_stack) {
    snprintf(sused, sizeof sused, "%u", st.stack_used);
    snprintf(sfree, sizeof sfree, "%u", st.stack_free);
  }
  if (h->bss_end)
    snprintf(bss, sizeof bss, "%u", h->bss_end);
  if (json) {
    f = fopen(h->stats_json, "w");
    if (!f) {
      warn("%s: %s", h->stats_json, strerror(errno));
      return;
    }
  }
  stat_kv_t kv[64];
  int n = 0;
#define KV(k, ...)                                                             \
  (kv[n].key = (k), kv[n].text = 0,                                            \
   snprintf(kv[n].val, sizeof kv[n].val, __VA_ARGS__), n++)
  KV("mcu", "%s", avr->mmcu);
  kv[n - 1].text = 1;
  KV("f_cpu", "%u", avr->frequency);
  if (h->pty && h->synthetic)
    KV("rows", "null");
  else
    KV("rows", "%llu", (unsigned long long)(h->pty ? h->file_rows : h->nrows));
  KV("rows_consumed", "%llu", (unsigned long long)adc_rows_consumed(h));
  KV("extra_scans", "%llu", (unsigned long long)h->extra_scans);
  KV("extra_conversions", "%llu", (unsigned long long)h->extra_conv);
  KV("sample_count", "%llu", (unsigned long long)h->pb0.count);
  KV("sample_cycles_mean", "%s", smean);
  KV("sample_cycles_max", "%s", smax);
  KV("allan_count", "%llu", (unsigned long long)h->pb2.count);
  KV("allan_cycles_mean", "%s", amean);
  KV("allan_cycles_max", "%s", amax);
  KV("isr_count", "%llu", (unsigned long long)h->pb1.count);
  KV("isr_cycles_mean", "%s", imean);
  KV("isr_cycles_max", "%s", imax);
  /* Whole interrupts, vector to reti (sim_isr.c), not the probe's window. */
  sim_isr_stat_t adc_isr = sim_isr_stat(h->adc->adc.vector),
                 any_isr = sim_isr_all();
  KV("isr_adc_cycles_mean", "%.1f",
     adc_isr.count ? (double)adc_isr.sum / adc_isr.count : 0.0);
  KV("isr_adc_cycles_max", "%llu", (unsigned long long)adc_isr.max);
  KV("isr_any_cycles_max", "%llu", (unsigned long long)any_isr.max);
  /* The ones that delay the ADC's and the tick's: the UART's and the tick's own. */
  avr_timer_t *t1 = (avr_timer_t *)find_io(avr, "timer", '1');
  sim_isr_stat_t rx_isr = sim_isr_stat(h->uart->rxc.vector),
                 udre_isr = sim_isr_stat(h->uart->udrc.vector),
                 tick_isr =
                     t1 ? sim_isr_stat(
                              t1->comp[AVR_TIMER_COMPA].interrupt.vector) :
                          (sim_isr_stat_t){ 0, 0, 0 };
  KV("isr_rx_cycles_max", "%llu", (unsigned long long)rx_isr.max);
  KV("isr_udre_cycles_max", "%llu", (unsigned long long)udre_isr.max);
  KV("isr_tick_cycles_max", "%llu", (unsigned long long)tick_isr.max);
  KV("adsc_after_adc_vector_max", "%llu",
     (unsigned long long)sim_isr_adsc_max(h->adc->adc.vector));
  KV("adsc_after_tick_max", "%llu",
     (unsigned long long)(t1 ? sim_isr_adsc_max(
                                   t1->comp[AVR_TIMER_COMPA].interrupt.vector) :
                               0));
  KV("cpu_busy_fraction", "%.6f", busy);
  KV("cycles_total", "%llu", (unsigned long long)avr->cycle);
  KV("cycles_slept", "%llu", (unsigned long long)h->slept);
  KV("ram_end", "%u", (unsigned)avr->ramend);
  KV("bss_end", "%s", bss);
  KV("stack_used_bytes", "%s", sused);
  KV("stack_free_bytes", "%s", sfree);
  KV("stack_sp_min", "%u", (unsigned)h->sp_min);
  KV("stack_sp_depth_bytes", "%u", (unsigned)(avr->ramend - h->sp_min));
  KV("stack_deepest_pc", "%lu", (unsigned long)h->sp_min_pc);
  KV("uart_bytes_out", "%llu", (unsigned long long)h->bytes_out);
  KV("uart_bytes_in", "%llu", (unsigned long long)h->bytes_in);
  KV("uart_xoff_events", "%llu", (unsigned long long)h->xoffs);
  KV("bad_crc_lines", "%llu", (unsigned long long)h->bad_crc);
  KV("device_n", "%s", dn);
  KV("boots", "%llu", (unsigned long long)h->boots);
  KV("restarts", "%llu", (unsigned long long)h->restarts);
  KV("first_row", "%llu", (unsigned long long)h->first_row);
  const fault_t *fl = &h->fault;
  KV("fault_in_lost", "%llu", (unsigned long long)fl->in_lost);
  KV("fault_in_flipped", "%llu", (unsigned long long)fl->in_flipped);
  KV("fault_in_frame_errors", "%llu", (unsigned long long)fl->in_frame_errors);
  KV("fault_in_data_flips", "%llu", (unsigned long long)fl->in_data_flips);
  KV("fault_out_lost", "%llu", (unsigned long long)fl->out_lost);
  KV("fault_out_flipped", "%llu", (unsigned long long)fl->out_flipped);
  KV("fault_overruns", "%llu", (unsigned long long)fl->overruns);
  KV("fault_overruns_injected", "%llu",
     (unsigned long long)fl->overruns_injected);
  KV("fault_dor_events", "%llu", (unsigned long long)fl->dor_events);
  KV("fault_eeprom_flipped", "%llu", (unsigned long long)fl->ee_flipped);
  KV("fault_resets", "%llu", (unsigned long long)fl->resets);
  KV("fault_adc_conversions", "%llu", (unsigned long long)fl->adc_faulted);
  KV("device_drops", "%s", dd);
  KV("sim_seconds", "%.6f", sim_s);
  KV("wall_seconds", "%.6f", h->wall_s);
  KV("sim_speed_x", "%.2f", h->wall_s > 0 ? sim_s / h->wall_s : 0.0);
#undef KV
  write_stats(h, f, kv, n, json);
}

void measure_connect(harness_t *h)
{
  sleep_h = h;
  h->avr->sleep = no_sleep;
  avr_irq_t *pb = avr_io_getirq(h->avr, AVR_IOCTL_IOPORT_GETIRQ('B'), 0);
  if (pb) {
    avr_irq_register_notify(pb + IOPORT_IRQ_PIN0, pb0_notify, h);
    avr_irq_register_notify(pb + IOPORT_IRQ_PIN1, pb1_notify, h);
    avr_irq_register_notify(pb + IOPORT_IRQ_PIN2, pb2_notify, h);
  }
}
