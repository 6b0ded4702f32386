/*
 * sim_cli.c - imu-sim's command line: --help and the options into h->
 */
#include "sim_cli.h"

#include <errno.h>
#include <getopt.h>
#include <stdlib.h>
#include <string.h>

#include "sim_fault.h"
#include "sim_msg.h"

/* --help: the batch run and its options, terminal mode, the figures. */
static const char usage_run[] =
    "Usage: imu-sim [options] --adc FILE ELF\n"
    "       imu-sim --pty [--link PATH] (--adc FILE | --synthetic) [--fast] ELF\n"
    "\n"
    "Run the imu-allan firmware ELF on a simulated AVR (simavr), feed its ADC\n"
    "the rows of FILE and capture what it sends on its serial port.  With\n"
    "--pty the serial port is a pseudo-terminal instead, for a person or a\n"
    "program to drive the device (see Terminal mode below).\n"
    "\n"
    "What happens (without --pty):\n"
    "  1. The firmware boots and samples at once; every conversion reads the\n"
    "     neutral code 512 until the harness is armed.\n"
    "  2. After the device's boot line ($B) the harness sends 'stop' and waits\n"
    "     for its '$ok'; from then on the i-th conversion of ADC mux channel j\n"
    "     reads column j of row i, exactly (j = 0..6: ax ay az gx gy gz temp).\n"
    "     Conversions started with the ADC interrupt off (the firmware's\n"
    "     start-up conversion) are not a scan's: they read 512 and take no row.\n"
    "  3. It sends 'rate HZ' (with --fs), 'reset' and 'start R', R being the\n"
    "     number of rows, each after the previous one's '$ok'.\n"
    "  4. Once mux 6 of the last row was converted, it sends 'report', waits\n"
    "     for the end line ($E) of the report that follows the reply and\n"
    "     exits 0.  Conversions after the last row read the last row again and\n"
    "     are reported as a warning (the device dropped samples).\n"
    "Host bytes go to the device at the firmware's baud rate (one byte time\n"
    "each), honouring simavr's receive FIFO flow control (unless\n"
    "--no-flow-control, see Faults).  Simulated time\n"
    "runs as fast as the host can go; idle (sleep) time costs nothing.\n"
    "\n"
    "Options:\n"
    "  --adc FILE        ADC rows, '-' for stdin (required without --pty).  One\n"
    "                    row per line: 7 integer codes 0..1023 separated by\n"
    "                    tabs or spaces; blank lines, '#' comments (whole line\n"
    "                    or trailing) and lines starting with '$' (the count\n"
    "                    lines and replies in a capture of the device's 'mode\n"
    "                    raw' output, which replays as is) are skipped.  The whole\n"
    "                    file is checked before the simulation starts (stdin is\n"
    "                    copied to a temporary file for that); a bad row stops\n"
    "                    with 'imu-sim: FILE:LINE: reason' (LINE: line number\n"
    "                    in the file) and exit status 2.  Codes of mux channels\n"
    "                    other than 0..6 read 0 (with a warning).\n"
    "  --fs HZ           send 'rate HZ' before 'reset' (default: firmware's rate)\n"
    "  --uart-in FILE    timed host input ('-' for stdin).  Lines\n"
    "                    '<N><TAB><text>': text is sent once N rows have been\n"
    "                    consumed, i.e. mux 6 of row N-1 was converted (N=0:\n"
    "                    right after 'start' was acknowledged); N must not\n"
    "                    decrease from line to line.\n"
    "                    Text is sent as is, with escapes \\r \\n \\t \\\\ \\xNN;\n"
    "                    end a command with \\r yourself (e.h-> '500<TAB>report\\r').\n"
    "                    '#' lines and blank lines are skipped.  Replies to these\n"
    "                    commands are only captured, never acted upon.\n"
    "  -o, --output FILE everything the device sends, bytes as they are\n"
    "                    (default: stdout)\n"
    "  --mcu NAME        MCU (default: from the ELF's .mmcu section, else\n"
    "                    atmega168)\n"
    "  --freq HZ         CPU clock (default: from .mmcu, else 10000000)\n"
    "  --timeout SEC     simulated seconds to wait for each expected line, and\n"
    "                    for each row while sampling (default 5)\n"
    "  --stats           print measured figures on stderr, one 'key value' a line\n"
    "  --stats-json FILE the same figures as a JSON object in FILE\n"
    "                    (--stats=FILE is the same as --stats-json FILE)\n"
    "  -v, --verbose     show simavr's own output and all its warnings;\n"
    "                    -vv adds simavr trace messages\n"
    "  -h, --help        this text\n"
    "\n";

static const char usage_term[] =
    "Terminal mode:\n"
    "  --pty             the device's serial port on a new pseudo-terminal; its\n"
    "                    path goes to stdout ('imu-sim: device on /dev/pts/N').\n"
    "                    The harness sends no command of its own: the firmware\n"
    "                    boots, samples at its defaults and answers whoever\n"
    "                    writes to the terminal (picocom -b 115200 PATH,\n"
    "                    imu-allan monitor --port PATH, pyserial; the baud\n"
    "                    rate set on the terminal does not matter).  Every\n"
    "                    conversion reads the next input row, from the first.\n"
    "                    The device powers up when a terminal first opens the\n"
    "                    port (0.2 s later, so that it sees the boot line), and\n"
    "                    runs until SIGINT, SIGTERM or SIGHUP (exit 0); a\n"
    "                    terminal may close and open it again meanwhile.\n"
    "                    What the device sends while no terminal is open is\n"
    "                    lost, as on a serial line with nothing attached.\n"
    "                    Typed or pasted bytes reach the device one byte time\n"
    "                    apart at the firmware's baud rate, honouring simavr's\n"
    "                    receive FIFO flow control; a long paste waits in the\n"
    "                    pty, not in the device.\n"
    "  --link PATH       also make a symbolic link PATH -> the pty (replacing a\n"
    "                    symlink already there); removed at exit\n"
    "  --adc FILE        rows as above, served in order and again from the\n"
    "                    first row after the last\n"
    "  --synthetic       rows from a built-in IMU instead: seeded white noise,\n"
    "                    codes ax ay az gx gy gz temp around 498 494 791 520\n"
    "                    497 498 63, sigma 2.0 2.5 1.7 0.9 0.67 0.57 0.5 counts\n"
    "  --seed N          seed of --synthetic (default 1)\n"
    "  --realtime        simulated time follows the wall clock, idle time too:\n"
    "                    100 Hz is 100 samples a second, a 60 s report interval\n"
    "                    is a minute (default).  A host too slow for that\n"
    "                    gets a warning, and simulated time falls behind.\n"
    "  --fast            simulated time runs as fast as the host can go (some\n"
    "                    200 times real time while sampling); device output\n"
    "                    then waits for the terminal to read it, instead of\n"
    "                    being lost when it does not\n"
    "  --no-wait         power up at once, not when a terminal opens the port\n"
    "  --eeprom FILE     EEPROM contents at power-up, from address 0 (raw bytes;\n"
    "                    the rest reads 0xFF, as on a blank chip)\n"
    "  -o FILE           also keep a copy of everything the device sends\n"
    "  --fs, --uart-in and --timeout do not apply.\n"
    "\n"
    "Board mode (make sim-board):\n"
    "  imu-sim --pty --board PREFIX [--bootloader HEX|none] [--flash HEX]\n"
    "          [--mcu NAME] [--freq HZ] [--link PATH] (--adc FILE | --synthetic)\n"
    "  --board PREFIX    the board as it leaves the factory: no ELF; the flash\n"
    "                    is PREFIX.flash and the EEPROM PREFIX.eeprom (raw bytes,\n"
    "                    blank when missing), both written back as the firmware\n"
    "                    changes them, so they persist as on a chip.  It powers\n"
    "                    up at once (--no-wait); opening the port resets the MCU\n"
    "                    through its RESET pin, as the DTR auto-reset circuit of\n"
    "                    an Arduino-style board does, so a serial bootloader\n"
    "                    (avrdude -c arduino) needs no manual reset.  SIGUSR1\n"
    "                    hangs the firmware in its first 'rjmp .' (a stuck loop,\n"
    "                    for watchdog tests).\n"
    "  --bootloader HEX  put HEX in the boot section and reset into it (the\n"
    "                    fuses BOOTRST = 0, BOOTSZ = its size); 'none' (the\n"
    "                    default): reset at address 0\n"
    "  --flash HEX       before power-up, erase the application flash and write\n"
    "                    HEX, as an ISP programmer would\n"
    "\n";

static const char usage_faults[] =
    "Faults (what a real board meets; any mode, counted in --stats as fault_*):\n"
    "  --link-loss P     each byte on the link is lost with probability P, both\n"
    "                    ways (in a batch run only while the rows run: the\n"
    "                    harness's set-up and the final report pass clean)\n"
    "  --link-flip P     each byte is hit by a bit error with probability P, both\n"
    "                    ways: towards the device one bit of its 10-bit frame\n"
    "                    (a data bit changes the byte unseen, the stop bit is a\n"
    "                    framing error (FE), the start bit loses the byte);\n"
    "                    towards the host one of its 8 bits\n"
    "  --fault-seed N    seed of every random fault (default 1): a run repeats\n"
    "  --no-flow-control host bytes go at the baud rate whatever the device\n"
    "                    does, and the UART keeps only what the chip keeps (two\n"
    "                    frames and one in its shift register): a frame arriving\n"
    "                    when that is full is lost and DOR is set (a data overrun)\n"
    "  --uart-overrun P  each host byte is lost to a data overrun with\n"
    "                    probability P, as when the receive interrupt comes late:\n"
    "                    DOR is set with the next frame that arrives (overruns\n"
    "                    with no frame between them are one DOR event:\n"
    "                    fault_dor_events)\n"
    "  --uart-frame-error P  each host byte arrives with a framing error (FE:\n"
    "                    its stop bit read as 0, its data bits intact) with\n"
    "                    probability P (fault_in_frame_errors counts these and\n"
    "                    --link-flip's)\n"
    "  --eeprom-flip ADDR[:MASK]@SEC  at simulated second SEC, EEPROM byte ADDR\n"
    "                    is XORed with MASK (default 0x01); up to 8 of them\n"
    "  --power-cut WHEN  the supply is cut and comes back (a power-on reset):\n"
    "                    WHEN is a simulated second, 'report' (as the device\n"
    "                    sends the first L row of a report) or 'save' (right\n"
    "                    after the device wrote the first EEPROM byte)\n"
    "  --brown-out WHEN  the same, a brown-out reset (BORF)\n"
    "                    After a reset in a batch run the harness starts again\n"
    "                    (stop, rate, reset, start) from the next row; the final\n"
    "                    report covers rows first_row .. the last (--stats).\n"
    "  --adc-fault CH=CODE|stuck[@ROW]  from row ROW (default 0) on, channel CH\n"
    "                    (ax ay az gx gy gz temp, or 0..6) reads CODE (0 or 1023:\n"
    "                    railed), or stays at its value of row ROW-1 (stuck)\n"
    "\n";

static const char usage_figures[] =
    "Figures (--stats):\n"
    "  sample_cycles_mean/max, sample_count  CPU cycles PB0 stays high (the\n"
    "                    firmware raises it while it handles one sample set)\n"
    "  isr_cycles_mean/max, isr_count        the same for PB1 (ADC interrupt)\n"
    "  isr_adc_cycles_mean/max, isr_any_cycles_max  whole interrupts, from the\n"
    "                    jump to the vector to the end of reti: the ADC's,\n"
    "                    and the longest of any vector\n"
    "  isr_rx_cycles_max, isr_udre_cycles_max, isr_tick_cycles_max  the same\n"
    "                    for the UART's receive and transmit and Timer1 COMPA's\n"
    "  adsc_after_adc_vector_max, adsc_after_tick_max  cycles from the ADC's\n"
    "                    (Timer1 COMPA's) vector to the ADSC its ISR writes\n"
    "  allan_cycles_mean/max, allan_count    the same for PB2 (high around each\n"
    "                                        call into the Allan engine)\n"
    "  cpu_busy_fraction 1 - slept cycles / total cycles\n"
    "  stack_used_bytes, stack_free_bytes    SRAM is filled with 0xA5 before the\n"
    "                    run; the lowest overwritten byte above the end of .bss\n"
    "                    (__heap_start, else _end) marks the deepest stack;\n"
    "                    free = bytes between the end of .bss and that byte\n"
    "  stack_sp_min, stack_sp_depth_bytes    lowest stack pointer seen (checked\n"
    "                    after every instruction) and RAMEND minus it: counts\n"
    "                    reserved but unwritten frames too; below .bss = overflow\n"
    "  sim_seconds, wall_seconds, sim_speed_x  simulated and host time of the\n"
    "                    simulation, and their ratio\n"
    "  rows_consumed, extra_scans, device_n, device_drops (from the final $H),\n"
    "  uart_bytes_in/out, uart_xoff_events (simavr's receive FIFO was full),\n"
    "  bad_crc_lines, cycles_total, cycles_slept\n"
    "  Unmeasured figures are null.\n"
    "\n"
    "Exit status: 0 done; 1 firmware crash or halt, device error reply, or\n"
    "another run failure; 2 bad command line or input file; 3 the device did\n"
    "not answer within --timeout simulated seconds.  Failures print one line.\n"
    "With --pty: 0 after SIGINT, SIGTERM or SIGHUP; 1 firmware crash or halt,\n"
    "or no pty; 2 bad command line, input file or --link PATH.\n";

static void usage(FILE *f)
{
  fputs(usage_run, f);
  fputs(usage_term, f);
  fputs(usage_faults, f);
  fputs(usage_figures, f);
}

static unsigned long parse_ulong(const char *s, const char *opt)
{
  char *end;
  errno = 0;
  unsigned long v = strtoul(s, &end, 0);
  if (!*s || *end || errno || *s == '-')
    die(EXIT_INPUT, "%s: '%s' is not a positive integer (see --help)", opt, s);
  return v;
}

static double parse_prob(const char *s, const char *opt)
{
  char *end;
  double v = strtod(s, &end);
  if (!*s || *end || !(v >= 0 && v <= 1))
    die(EXIT_INPUT, "%s: '%s' is not a probability (0 to 1)", opt, s);
  return v;
}

/* Options that exclude each other or need another. */
static void check_args(const harness_t *h)
{
  if ((h->bootloader || h->isp_hex) && !h->board)
    die(EXIT_INPUT, "%s only applies with --board (see --help)",
        h->bootloader ? "--bootloader" : "--flash");
  if (h->board && !h->pty)
    die(EXIT_INPUT,
        "--board needs --pty: the board's port is a pseudo-terminal");
  if (h->board && h->eeprom_path)
    die(EXIT_INPUT, "--eeprom does not apply with --board: its EEPROM is "
                    "kept in PREFIX.eeprom");
  if (!h->pty) {
    const char *only = h->link_path ? "--link" :
                       h->synthetic ? "--synthetic" :
                       h->fast      ? "--fast" :
                       h->realtime  ? "--realtime" :
                       h->no_wait   ? "--no-wait" :
                       h->seed != 1 ? "--seed" :
                                      NULL;
    if (only)
      die(EXIT_INPUT, "%s only applies with --pty (see --help)", only);
  } else {
    const char *not = h->fs           ? "--fs" :
                      h->uart_in_path ? "--uart-in" :
                      h->timeout_set  ? "--timeout" :
                                        NULL;
    if (not )
      die(EXIT_INPUT,
          "%s does not apply with --pty: the terminal drives "
          "the device (see --help)",
          not );
    if (h->fast && h->realtime)
      die(EXIT_INPUT, "--fast and --realtime exclude each other");
    if (h->synthetic && h->adc_path)
      die(EXIT_INPUT, "--adc and --synthetic exclude each other");
    if (!h->synthetic && !h->adc_path)
      die(EXIT_INPUT, "--pty needs --adc FILE or --synthetic (see --help)");
    return;
  }
  if (!h->adc_path)
    die(EXIT_INPUT, "--adc FILE is required (see --help)");
  if (h->fs && h->fs > 100000)
    die(EXIT_INPUT, "--fs: %u Hz is not a sample rate", h->fs);
  if (h->uart_in_path && !strcmp(h->uart_in_path, "-") &&
      !strcmp(h->adc_path, "-"))
    die(EXIT_INPUT, "--adc and --uart-in cannot both read stdin");
}

/* imu-sim's long options (getopt_long). */
enum {
  O_ADC = 256,
  O_FS,
  O_UART_IN,
  O_MCU,
  O_FREQ,
  O_TIMEOUT,
  O_STATS,
  O_STATS_JSON,
  O_PTY,
  O_LINK,
  O_SYNTHETIC,
  O_SEED,
  O_REALTIME,
  O_FAST,
  O_NO_WAIT,
  O_EEPROM,
  O_BOARD,
  O_BOOTLOADER,
  O_FLASH,
  O_LINK_LOSS,
  O_LINK_FLIP,
  O_FAULT_SEED,
  O_NO_FLOW,
  O_OVERRUN,
  O_FRAME,
  O_EE_FLIP,
  O_POWER_CUT,
  O_BROWN_OUT,
  O_ADC_FAULT
};
static const struct option opts[] = {
  { "adc", required_argument, NULL, O_ADC },
  { "fs", required_argument, NULL, O_FS },
  { "uart-in", required_argument, NULL, O_UART_IN },
  { "output", required_argument, NULL, 'o' },
  { "mcu", required_argument, NULL, O_MCU },
  { "freq", required_argument, NULL, O_FREQ },
  { "timeout", required_argument, NULL, O_TIMEOUT },
  { "stats", optional_argument, NULL, O_STATS },
  { "stats-json", required_argument, NULL, O_STATS_JSON },
  { "pty", no_argument, NULL, O_PTY },
  { "link", required_argument, NULL, O_LINK },
  { "synthetic", no_argument, NULL, O_SYNTHETIC },
  { "seed", required_argument, NULL, O_SEED },
  { "realtime", no_argument, NULL, O_REALTIME },
  { "fast", no_argument, NULL, O_FAST },
  { "no-wait", no_argument, NULL, O_NO_WAIT },
  { "eeprom", required_argument, NULL, O_EEPROM },
  { "board", required_argument, NULL, O_BOARD },
  { "bootloader", required_argument, NULL, O_BOOTLOADER },
  { "flash", required_argument, NULL, O_FLASH },
  { "link-loss", required_argument, NULL, O_LINK_LOSS },
  { "link-flip", required_argument, NULL, O_LINK_FLIP },
  { "fault-seed", required_argument, NULL, O_FAULT_SEED },
  { "no-flow-control", no_argument, NULL, O_NO_FLOW },
  { "uart-overrun", required_argument, NULL, O_OVERRUN },
  { "uart-frame-error", required_argument, NULL, O_FRAME },
  { "eeprom-flip", required_argument, NULL, O_EE_FLIP },
  { "power-cut", required_argument, NULL, O_POWER_CUT },
  { "brown-out", required_argument, NULL, O_BROWN_OUT },
  { "adc-fault", required_argument, NULL, O_ADC_FAULT },
  { "verbose", no_argument, NULL, 'v' },
  { "help", no_argument, NULL, 'h' },
  { NULL, 0, NULL, 0 },
};

void parse_args(harness_t *h, int argc, char **argv)
{
  int c;
  h->fault.rng = 0x9E3779B97F4A7C15ull + 1; /* --fault-seed 1 */
  opterr = 0;
  while ((c = getopt_long(argc, argv, ":o:vh", opts, NULL)) != -1) {
    switch (c) {
    case O_ADC: h->adc_path = optarg; break;
    case O_FS: h->fs = (unsigned)parse_ulong(optarg, "--fs"); break;
    case O_UART_IN: h->uart_in_path = optarg; break;
    case 'o': h->out_path = optarg; break;
    case O_MCU: h->mcu = optarg; break;
    case O_FREQ: h->freq = (uint32_t)parse_ulong(optarg, "--freq"); break;
    case O_TIMEOUT: {
      char *end;
      h->timeout_s = strtod(optarg, &end);
      h->timeout_set = 1;
      if (*end || !(h->timeout_s > 0))
        die(EXIT_INPUT, "--timeout: '%s' is not a positive number of seconds",
            optarg);
      break;
    }
    case O_STATS:
      if (optarg)
        h->stats_json = optarg;
      else
        h->stats_text = 1;
      break;
    case O_STATS_JSON: h->stats_json = optarg; break;
    case O_PTY: h->pty = 1; break;
    case O_LINK: h->link_path = optarg; break;
    case O_SYNTHETIC: h->synthetic = 1; break;
    case O_SEED: h->seed = parse_ulong(optarg, "--seed"); break;
    case O_REALTIME: h->realtime = 1; break;
    case O_FAST: h->fast = 1; break;
    case O_NO_WAIT: h->no_wait = 1; break;
    case O_EEPROM: h->eeprom_path = optarg; break;
    case O_BOARD: h->board = optarg; break;
    case O_BOOTLOADER: h->bootloader = optarg; break;
    case O_FLASH: h->isp_hex = optarg; break;
    case O_LINK_LOSS: h->fault.loss = parse_prob(optarg, "--link-loss"); break;
    case O_LINK_FLIP: h->fault.flip = parse_prob(optarg, "--link-flip"); break;
    case O_FAULT_SEED:
      h->fault.rng =
          parse_ulong(optarg, "--fault-seed") * 0x9E3779B97F4A7C15ull + 1;
      break;
    case O_NO_FLOW: h->fault.no_flow = 1; break;
    case O_OVERRUN:
      h->fault.overrun = parse_prob(optarg, "--uart-overrun");
      break;
    case O_FRAME:
      h->fault.frame = parse_prob(optarg, "--uart-frame-error");
      break;
    case O_EE_FLIP: fault_parse_eeprom(&h->fault, optarg); break;
    case O_POWER_CUT: fault_parse_power(&h->fault, POWER_CUT, optarg); break;
    case O_BROWN_OUT:
      fault_parse_power(&h->fault, POWER_BROWNOUT, optarg);
      break;
    case O_ADC_FAULT: fault_parse_adc(&h->fault, optarg); break;
    case 'v': h->verbose++; break;
    case 'h': usage(stdout); exit(EXIT_OK);
    case ':':
      die(EXIT_INPUT, "%s needs an argument (see --help)", argv[optind - 1]);
    default:
      die(EXIT_INPUT, "unknown option '%s' (see --help)", argv[optind - 1]);
    }
  }
  if (h->board && optind == argc) {
    check_args(h); /* board mode: the firmware is in the board's flash */
    return;
  }
  if (optind == argc)
    die(EXIT_INPUT, "missing the firmware ELF file (see --help)");
  if (h->board)
    die(EXIT_INPUT, "--board takes no ELF: the firmware is what the board's "
                    "flash holds (--flash HEX to program one)");
  if (optind != argc - 1)
    die(EXIT_INPUT, "expected one ELF file, got %d arguments (see --help)",
        argc - optind);
  h->elf_path = argv[optind];
  check_args(h);
}
