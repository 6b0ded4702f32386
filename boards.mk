# boards.mk - put the firmware on a board with avrdude, the way Arduino and
# Grbl users do (included by the top-level Makefile: MCU, F_CPU, BUILD come
# from it).
#
#   make flash PORT=/dev/ttyUSB0         through a serial bootloader
#                                        (PROGRAMMER=arduino, the default)
#   make flash PROGRAMMER=usbasp         through an ISP programmer (no port)
#   make flash PROGRAMMER=stk500v1 PORT=/dev/ttyACM0 BAUD_PROG=19200
#                                        through an "Arduino as ISP"
#   make fuses PROGRAMMER=usbasp CONFIRM=yes [BOOTLOADER=1]
#                                        set the clock, brown-out and boot
#                                        fuses of the board (ISP only)
#   make flash-dryrun / make fuses-dryrun (or PRINT=1 on either)
#                                        print the avrdude command, run nothing
#
# Variables: PROGRAMMER (avrdude -c), PORT (-P), BAUD_PROG (-b), AVRDUDE,
# AVRDUDE_FLAGS (e.g. -B 10 to slow an ISP clock down for a chip still on
# its factory 1 MHz clock), BOOTLOADER=1 (the chip carries a 1 KB
# bootloader), LFUSE/HFUSE/EFUSE (override the table below).

# This fragment must not change the default goal of the including Makefile.
BOARDS_MK_DEFAULT_GOAL := $(.DEFAULT_GOAL)

AVRDUDE ?= avrdude
PROGRAMMER ?= arduino
PORT ?=
BAUD_PROG ?=
AVRDUDE_FLAGS ?=
BOOTLOADER ?= 0
CONFIRM ?=
PRINT ?=

# avrdude's part names
AVRDUDE_PART_atmega168 := m168
AVRDUDE_PART_atmega168p := m168p
AVRDUDE_PART_atmega328p := m328p
AVRDUDE_PART = $(or $(AVRDUDE_PART_$(MCU)),$(MCU))

FLASH_HEX = $(BUILD)/avr-$(MCU)/imu-allan.hex

# Programmers that talk through a serial port (they need PORT=), and those
# that are a bootloader on the chip itself (they cannot write fuses; the
# bootloader erases each page it writes, hence -D).
PORT_PROGRAMMERS := arduino urclock stk500v1 stk500v2 stk500 avr109 butterfly \
                    wiring buspirate buspirate_bb
BOOTLOADER_PROGRAMMERS := arduino urclock avr109 butterfly wiring

AVRDUDE_CMD = $(AVRDUDE) -p $(AVRDUDE_PART) -c $(PROGRAMMER)$(if $(PORT), -P $(PORT))$(if \
  $(BAUD_PROG), -b $(BAUD_PROG))$(if $(AVRDUDE_FLAGS), $(AVRDUDE_FLAGS))
FLASH_CMD = $(AVRDUDE_CMD)$(if $(filter $(PROGRAMMER),$(BOOTLOADER_PROGRAMMERS)), -D) \
  -U flash:w:$(FLASH_HEX):i
FUSES_CMD = $(AVRDUDE_CMD) -U lfuse:w:$(LFUSE):m -U hfuse:w:$(HFUSE):m -U efuse:w:$(EFUSE):m

# ---- fuses -----------------------------------------------------------------
# The board: external crystal (F_CPU, 10 MHz) at 3.3 V.  A fuse bit is 0 when
# "programmed" (active) and 1 when not.  From the ATmega48/88/168 and
# ATmega328P datasheets (Memory Programming: Fuse Bits; System Clock).
#
# ATmega168 low fuse 0xFF = 1111 1111
#   bit 7   CKDIV8 = 1    clock not divided by 8: the CPU runs at F_CPU
#   bit 6   CKOUT  = 1    no clock output on PB0 (the firmware uses PB0)
#   bit 5-4 SUT    = 11   with CKSEL0 = 1: crystal, slowly rising power:
#                         16K CK start-up + 14 CK + 65 ms after reset
#   bit 3-1 CKSEL  = 111  low power crystal oscillator, 8.0-16.0 MHz
#   bit 0   CKSEL0 = 1    (crystal, see SUT)
#   (0xF7, CKSEL 0111: full swing crystal oscillator, for a noisy board)
# ATmega168 high fuse 0xDD = 1101 1101
#   bit 7   RSTDISBL = 1  the RESET pin stays a reset (ISP needs it)
#   bit 6   DWEN     = 1  no debugWIRE (it would take the RESET pin)
#   bit 5   SPIEN    = 0  serial (ISP) programming enabled
#   bit 4   WDTON    = 1  the watchdog is not forced on
#   bit 3   EESAVE   = 1  a chip erase also clears the EEPROM (saved settings
#                         go back to the defaults; 0xD5 keeps them)
#   bit 2-0 BODLEVEL = 101 brown-out reset at 2.7 V (2.5-2.9 V): 10 MHz
#                         is within the speed grade from 2.7 V up
# ATmega168 extended fuse (bits 7-3 unused, read as 1)
#   0xF9 = 1111 1001  no bootloader: BOOTSZ = 00, BOOTRST = 1 (reset at
#                     0x0000; the factory value)
#   0xFA = 1111 1010  BOOTLOADER=1: BOOTSZ = 01, a 512-word (1 KB) boot
#                     section at word 0x1E00 (byte 0x3C00); BOOTRST = 0,
#                     reset jumps to the bootloader
#
# ATmega328P: the same clock (low 0xFF) and brown-out, but BOOTSZ/BOOTRST
# are in the high fuse and BODLEVEL in the extended one:
#   high 0xD9 = 1101 1001 (no bootloader: BOOTSZ = 00, BOOTRST = 1, factory)
#   high 0xDC = 1101 1100 (BOOTLOADER=1: BOOTSZ = 10, 512 words at word
#               0x3E00 (byte 0x7C00), BOOTRST = 0)
#   extended 0xFD = 1111 1101 (BODLEVEL = 101, 2.7 V)
LFUSE_atmega168 := 0xFF
HFUSE_atmega168 := 0xDD
EFUSE_atmega168_0 := 0xF9
EFUSE_atmega168_1 := 0xFA
LFUSE_atmega328p := 0xFF
HFUSE_atmega328p_0 := 0xD9
HFUSE_atmega328p_1 := 0xDC
EFUSE_atmega328p := 0xFD

LFUSE ?= $(LFUSE_$(MCU))
HFUSE ?= $(or $(HFUSE_$(MCU)),$(HFUSE_$(MCU)_$(BOOTLOADER)))
EFUSE ?= $(or $(EFUSE_$(MCU)),$(EFUSE_$(MCU)_$(BOOTLOADER)))

# what `make fuses` prints about the values (table values only)
fuse_text = $(if $(filter file,$(origin $(1))),$(2),as given)
FUSES_BOOT_TEXT = $(if $(filter 1,$(BOOTLOADER)),1 KB boot section and reset into it,no bootloader (reset at 0))
FUSES_TEXT_atmega168 = \
  "  lfuse $(LFUSE): $(call fuse_text,LFUSE,external crystal 8-16 MHz (low power)$(comma) slowly rising power$(comma) no /8)" \
  "  hfuse $(HFUSE): $(call fuse_text,HFUSE,brown-out at 2.7 V$(comma) ISP enabled$(comma) RESET kept$(comma) no debugWIRE)" \
  "  efuse $(EFUSE): $(call fuse_text,EFUSE,$(FUSES_BOOT_TEXT))"
FUSES_TEXT_atmega328p = \
  "  lfuse $(LFUSE): $(call fuse_text,LFUSE,external crystal 8-16 MHz (low power)$(comma) slowly rising power$(comma) no /8)" \
  "  hfuse $(HFUSE): $(call fuse_text,HFUSE,ISP enabled$(comma) RESET kept$(comma) no debugWIRE$(comma) $(FUSES_BOOT_TEXT))" \
  "  efuse $(EFUSE): $(call fuse_text,EFUSE,brown-out at 2.7 V)"
comma := ,

# ---- checks: before anything is built, one line --------------------------
BOARDS_GOALS := $(filter flash flash-dryrun fuses fuses-dryrun,$(MAKECMDGOALS))
BOARDS_FUSES := $(filter fuses fuses-dryrun,$(MAKECMDGOALS))
ifneq ($(BOARDS_FUSES),)
  ifneq ($(filter $(PROGRAMMER),$(BOOTLOADER_PROGRAMMERS)),)
    $(error PROGRAMMER=$(PROGRAMMER) is a bootloader and cannot write fuses: use an ISP programmer, e.g. make $(firstword $(BOARDS_FUSES)) PROGRAMMER=usbasp (or PROGRAMMER=stk500v1 PORT=... for an Arduino as ISP))
  endif
  ifeq ($(filter 0 1,$(BOOTLOADER)),)
    $(error BOOTLOADER=$(BOOTLOADER): give 0 (no bootloader, the default) or 1 (a 1 KB bootloader))
  endif
  ifeq ($(and $(LFUSE),$(HFUSE),$(EFUSE)),)
    $(error no fuse values for MCU=$(MCU) (known: atmega168, atmega328p): give LFUSE= HFUSE= EFUSE=)
  endif
  ifeq ($(origin LFUSE),file)
    ifneq ($(shell [ $(F_CPU) -ge 8000000 ] && [ $(F_CPU) -le 16000000 ] && echo ok),ok)
      $(error the low fuse $(LFUSE) is for an 8-16 MHz crystal, not F_CPU=$(F_CPU): give LFUSE=)
    endif
  endif
endif
ifneq ($(BOARDS_GOALS),)
  ifeq ($(strip $(PORT)),)
    ifneq ($(filter $(PROGRAMMER),$(PORT_PROGRAMMERS)),)
      $(error PROGRAMMER=$(PROGRAMMER) needs the serial port: make $(firstword $(BOARDS_GOALS)) PORT=/dev/ttyUSB0 (or /dev/ttyACM0 ...; see ls /dev/tty*))
    endif
  endif
endif

# ---- targets ---------------------------------------------------------------
.PHONY: flash flash-dryrun fuses fuses-dryrun

flash: $(if $(PRINT),,firmware)
	$(if $(PRINT),@echo '$(FLASH_CMD)',$(FLASH_CMD))

flash-dryrun:
	@echo '$(FLASH_CMD)'

fuses fuses-dryrun:
	@echo "fuses for $(MCU) at F_CPU=$(F_CPU) on a 3.3 V board (see boards.mk):"
	@for l in $(FUSES_TEXT_$(MCU)); do echo "$$l"; done
	@if [ -n "$(PRINT)" ] || [ "$@" = fuses-dryrun ]; then echo '$(FUSES_CMD)'; exit 0; fi; \
	if [ "$(CONFIRM)" != yes ]; then \
	  echo '$(FUSES_CMD)'; \
	  echo "boards.mk: nothing written: wrong fuses can lock a chip out (a wrong clock setting needs an external clock or a high-voltage programmer to recover); check the values above, then: make fuses PROGRAMMER=$(PROGRAMMER)$(if $(PORT), PORT=$(PORT))$(if $(filter 1,$(BOOTLOADER)), BOOTLOADER=1) CONFIRM=yes" >&2; \
	  exit 1; \
	fi; \
	echo '$(FUSES_CMD)'; $(FUSES_CMD)

.DEFAULT_GOAL := $(BOARDS_MK_DEFAULT_GOAL)
