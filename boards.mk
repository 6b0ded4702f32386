# boards.mk - put the firmware on a board with avrdude, the way Arduino and
# Grbl users do (included by the top-level Makefile: MCU, F_CPU, BUILD come
# from it).
#
#   make flash PORT=/dev/ttyUSB0         through a serial bootloader
#                                        (PROGRAMMER=arduino, the default)
#   make flash PROGRAMMER=usbasp         through an ISP programmer (no port)
#   make flash PROGRAMMER=stk500v1 PORT=/dev/ttyACM0 BAUD_PROG=19200
#                                        through an "Arduino as ISP"
#   make fuses PROGRAMMER=usbasp CONFIRM=yes [BOOTLOADER=...]
#                                        set the clock, brown-out and boot
#                                        fuses of the board (ISP only)
#   make flash-dryrun / make fuses-dryrun (or PRINT=1 on either)
#                                        print the avrdude command, run nothing
#   make bootloader                      build optiboot for the board into
#                                        $(BUILD)/optiboot/ (BOOTLOADER=optiboot)
#   make bootloader-flash PROGRAMMER=usbasp CONFIRM=yes
#                                        put it on a chip through ISP
#   make sim-board                       the simulated board with optiboot,
#                                        its port on $(BUILD)/imu-board, for
#                                        make flash PORT=$(BUILD)/imu-board
#
# Variables: PROGRAMMER (avrdude -c), PORT (-P), BAUD_PROG (-b), AVRDUDE,
# AVRDUDE_FLAGS (e.g. -B 10 to slow an ISP clock down for a chip still on
# its factory 1 MHz clock), BOOTLOADER (below), BOOTLOADER_HEX (a
# bootloader of your own, for make bootloader-flash and make sim-board),
# LFUSE/HFUSE/EFUSE (override the table below).

# This fragment must not change the default goal of the including Makefile.
BOARDS_MK_DEFAULT_GOAL := $(.DEFAULT_GOAL)

AVRDUDE ?= avrdude
PROGRAMMER ?= arduino
PORT ?=
BAUD_PROG ?=
AVRDUDE_FLAGS ?=
CONFIRM ?=
PRINT ?=

# avrdude's part names
AVRDUDE_PART_atmega168 := m168
AVRDUDE_PART_atmega168p := m168p
AVRDUDE_PART_atmega328p := m328p
AVRDUDE_PART = $(or $(AVRDUDE_PART_$(MCU)),$(MCU))

# FLASH_ELF=another.elf flashes a firmware built elsewhere (its .hex beside it);
# make flash first checks that it was built for this MCU, F_CPU and BAUD.
# FLASH_HEX=file.hex flashes a bare .hex as given (it carries no identity).
FLASH_ELF ?= $(BUILD)/avr-$(MCU)/imu-allan.elf
FLASH_HEX = $(FLASH_ELF:.elf=.hex)

# Programmers that talk through a serial port (they need PORT=), and those
# that are a bootloader on the chip itself (they cannot write fuses; the
# bootloader erases each page it writes, hence -D).
PORT_PROGRAMMERS := arduino urclock stk500v1 stk500v2 stk500 avr109 butterfly \
                    wiring buspirate buspirate_bb
BOOTLOADER_PROGRAMMERS := arduino urclock avr109 butterfly wiring

AVRDUDE_CMD = $(AVRDUDE) -p $(AVRDUDE_PART) -c $(PROGRAMMER)$(if $(PORT), -P $(PORT))$(if \
  $(BAUD_PROG), -b $(BAUD_PROG))$(if $(AVRDUDE_FLAGS), $(AVRDUDE_FLAGS))
# Through ISP, avrdude erases the whole chip first, the bootloader too: it is
# written back in the same run (BOOTLOADER_HEX), so the chip stays as its
# fuses expect.
FLASH_CMD = $(AVRDUDE_CMD)$(if $(filter $(PROGRAMMER),$(BOOTLOADER_PROGRAMMERS)), -D) \
  -U flash:w:$(FLASH_HEX):i$(if $(filter-out $(BOOTLOADER_PROGRAMMERS),$(PROGRAMMER)),$(if \
  $(BOOTLOADER_HEX), -U flash:w:$(BOOTLOADER_HEX):i))
FUSES_CMD = $(AVRDUDE_CMD) -U lfuse:w:$(LFUSE):m -U hfuse:w:$(HFUSE):m -U efuse:w:$(EFUSE):m


# ---- bootloader: the boot section and what is left for the firmware --------
# BOOTLOADER=optiboot (default): Arduino's optiboot, 512 bytes, built from
#   Debian's arduino-core-avr for this board's F_CPU and BAUD;
# BOOTLOADER=none: no bootloader (flash through ISP; the whole flash is
#   the firmware's);
# BOOTLOADER=<bytes>: a boot section of that size (256, 512, 1024, 2048 on
#   the ATmega168; 512 ... 4096 on the ATmega328P), with BOOTLOADER_HEX=
#   the bootloader that goes in it.  BOOTLOADER=0 and 1 keep their former
#   meanings: none, and 1024 bytes.
BOOTLOADER ?= optiboot
FLASH_BYTES_atmega168 := 16384
FLASH_BYTES_atmega168p := 16384
FLASH_BYTES_atmega328p := 32768
FLASH_BYTES = $(FLASH_BYTES_$(MCU))
BOOT_SIZES_16384 := 256 512 1024 2048
BOOT_SIZES_32768 := 512 1024 2048 4096
BOOT_BYTES := $(strip $(if $(filter optiboot,$(BOOTLOADER)),512,$(if \
  $(filter none 0,$(BOOTLOADER)),0,$(if $(filter 1,$(BOOTLOADER)),1024,$(BOOTLOADER)))))
APP_MAX_BYTES = $(shell echo $$(( $(FLASH_BYTES) - $(BOOT_BYTES) )))
BOOT_START_HEX = $(shell printf '0x%x' $(APP_MAX_BYTES))

ifeq ($(filter 0,$(BOOT_BYTES)),)
  ifneq ($(FLASH_BYTES),)
    ifeq ($(filter $(BOOT_BYTES),$(BOOT_SIZES_$(FLASH_BYTES))),)
      $(error BOOTLOADER=$(BOOTLOADER): give optiboot, none, or a boot section size the $(MCU) has: $(BOOT_SIZES_$(FLASH_BYTES)) bytes)
    endif
  endif
endif

# optiboot, from the sources Debian's arduino-core-avr ships (make deps
# installs it).  Built with its own Makefile's flags, except
# LED_START_FLASHES=0: Debian's avr-gcc 5.4 makes the LED-flashing build
# 532 bytes, more than the 512-byte boot section, and board.h names no LED
# (optiboot's is on PB5, the ISP clock).  Its UART: U2X, UBRR = (F_CPU + 4 BAUD)/(8 BAUD) - 1 = 10
# at 10 MHz, 113,636 baud for 115,200: -1.4 %, as the firmware's own
# setting (uart.c) and within the 2 % a UART tolerates.  The hex files
# Debian ships are built for 16 MHz: at 10 MHz they would talk at 71 kbaud.
OPTIBOOT_DIR ?= /usr/share/arduino/hardware/arduino/avr/bootloaders/optiboot
OPTIBOOT_HEX := $(BUILD)/optiboot/optiboot_$(MCU)_$(F_CPU)_$(BAUD).hex
OPTIBOOT_CFLAGS = -g -Wall -Os -fno-inline-small-functions -fno-split-wide-types \
  -mshort-calls -mmcu=$(MCU) -DF_CPU=$(F_CPU)L -DBAUD_RATE=$(BAUD)L -DLED_START_FLASHES=0
OPTIBOOT_LDFLAGS = -Wl,--section-start=.text=$(BOOT_START_HEX) \
  -Wl,--section-start=.version=$(shell printf '0x%x' $$(( $(FLASH_BYTES) - 2 ))) \
  -Wl,--relax -Wl,--gc-sections -nostartfiles -nostdlib

ifeq ($(BOOTLOADER),optiboot)
BOOTLOADER_HEX ?= $(OPTIBOOT_HEX)
endif
BOOTLOADER_HEX ?=

$(OPTIBOOT_HEX): $(OPTIBOOT_DIR)/optiboot.c boards.mk
	@test -f $(OPTIBOOT_DIR)/optiboot.c || { echo "boards.mk: no optiboot source in $(OPTIBOOT_DIR): run make deps (Debian's arduino-core-avr)" >&2; exit 1; }
	@mkdir -p $(dir $@)
	$(AVR_CC) $(OPTIBOOT_CFLAGS) -Wno-unused-function $(OPTIBOOT_LDFLAGS) -o $(@:.hex=.elf) $<
	@size=$$($(AVR_SIZE) -A $(@:.hex=.elf) | awk '$$1==".text"{print $$2}'); \
	if [ $$size -gt 510 ]; then echo "boards.mk: optiboot is $$size bytes here, more than the 510 its 512-byte boot section holds beside its version word" >&2; exit 1; fi; \
	echo "optiboot for $(MCU) at $(F_CPU) Hz, $(BAUD) baud: $$size bytes at $(BOOT_START_HEX)"
	$(AVR_OBJCOPY) -j .text -j .data -j .version --set-section-flags .version=alloc,load -O ihex $(@:.hex=.elf) $@.tmp
	@# no start-address record (type 03): meaningless on an AVR, and simavr's reader complains
	@grep -v '^:04000003' $@.tmp > $@ && rm -f $@.tmp

# The firmware must end where the boot section begins: `make` prints the
# room left and refuses (deleting the hex, so nothing overlapping can be
# flashed) a firmware that would overwrite the bootloader.
firmware: flash-room
flash-room: $(HEX) ## the firmware's flash against the room the bootloader leaves (part of make firmware)
	@if [ -z "$(FLASH_BYTES)" ]; then echo "boards.mk: flash size of $(MCU) unknown: no room check"; exit 0; fi; \
	used=$$($(AVR_SIZE) --target=ihex $(HEX) | awk 'NR==2{print $$2}'); \
	room=$$(( $(APP_MAX_BYTES) - used )); \
	if [ $$room -lt 0 ]; then rm -f $(HEX); \
	  echo "boards.mk: the firmware is $$used bytes, $$(( -room )) more than the $(APP_MAX_BYTES) that BOOTLOADER=$(BOOTLOADER) leaves on the $(MCU): it would overwrite the bootloader" >&2; exit 1; fi; \
	echo "flash: $$used of $(APP_MAX_BYTES) bytes (BOOTLOADER=$(BOOTLOADER)), $$room left"

bootloader: $(if $(BOOTLOADER_HEX),$(BOOTLOADER_HEX)) ## build optiboot for this board into build/optiboot/
	@if [ -z "$(BOOTLOADER_HEX)" ]; then echo "boards.mk: BOOTLOADER=$(BOOTLOADER) has no bootloader hex: give BOOTLOADER_HEX=" >&2; exit 1; fi
	@echo "bootloader: $(BOOTLOADER_HEX)"

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
# ATmega168 extended fuse (bits 7-3 unused, read as 1): the boot section
#   bit 2-1 BOOTSZ  boot section size and start (datasheet table 27-7)
#   bit 0   BOOTRST 0: reset jumps to the boot section's start, 1: to 0x0000
#   BOOTLOADER=none      0xF9 = 1111 1001  BOOTSZ = 00, BOOTRST = 1 (reset at
#                                          0x0000; the factory value)
#   BOOTLOADER=256       0xFE = 1111 1110  BOOTSZ = 11, 128 words at byte 0x3F00
#   BOOTLOADER=optiboot  0xFC = 1111 1100  BOOTSZ = 10, 256 words (512 bytes)
#              (=512)                      at byte 0x3E00, BOOTRST = 0 (as
#                                          optiboot's own Makefile: 0x04)
#   BOOTLOADER=1024 (=1) 0xFA = 1111 1010  BOOTSZ = 01, 512 words at 0x3C00
#   BOOTLOADER=2048      0xF8 = 1111 1000  BOOTSZ = 00, 1024 words at 0x3800
#
# ATmega328P: the same clock (low 0xFF) and brown-out, but BOOTSZ/BOOTRST
# are the high fuse's bits 2-0 (its sizes are twice the ATmega168's for the
# same bits) and BODLEVEL is in the extended one:
#   high 1101 1 BOOTSZ BOOTRST: bits 7-3 as the ATmega168's high fuse
#   BOOTLOADER=none      0xD9 = 1101 1001  BOOTSZ = 00, BOOTRST = 1 (factory)
#   BOOTLOADER=optiboot  0xDE = 1101 1110  BOOTSZ = 11, 256 words (512 bytes)
#              (=512)                      at byte 0x7E00, BOOTRST = 0
#   BOOTLOADER=1024 (=1) 0xDC = 1101 1100  BOOTSZ = 10, 512 words at 0x7C00
#   BOOTLOADER=2048      0xDA = 1101 1010  BOOTSZ = 01, at 0x7800
#   BOOTLOADER=4096      0xD8 = 1101 1000  BOOTSZ = 00, at 0x7000
#   extended 0xFD = 1111 1101 (BODLEVEL = 101, 2.7 V)
#
# EESAVE (high fuse bit 3) decides whether a chip erase clears the EEPROM,
# i.e. the saved settings: an ISP `make flash` erases the chip first
# (avrdude without -D), so with EESAVE = 1 (the values above) it brings the
# settings back to the defaults; HFUSE=0xD5 (ATmega168; 0xD1/0xD6 ... on the
# ATmega328P: clear bit 3) keeps them.  Through the bootloader nothing
# erases the EEPROM: optiboot erases only each flash page it writes, and
# `make flash` passes -D anyway.
LFUSE_atmega168 := 0xFF
HFUSE_atmega168 := 0xDD
EFUSE_atmega168_0 := 0xF9
EFUSE_atmega168_256 := 0xFE
EFUSE_atmega168_512 := 0xFC
EFUSE_atmega168_1024 := 0xFA
EFUSE_atmega168_2048 := 0xF8
LFUSE_atmega328p := 0xFF
HFUSE_atmega328p_0 := 0xD9
HFUSE_atmega328p_512 := 0xDE
HFUSE_atmega328p_1024 := 0xDC
HFUSE_atmega328p_2048 := 0xDA
HFUSE_atmega328p_4096 := 0xD8
EFUSE_atmega328p := 0xFD

LFUSE ?= $(LFUSE_$(MCU))
HFUSE ?= $(or $(HFUSE_$(MCU)),$(HFUSE_$(MCU)_$(BOOT_BYTES)))
EFUSE ?= $(or $(EFUSE_$(MCU)),$(EFUSE_$(MCU)_$(BOOT_BYTES)))

# what `make fuses` prints about the values (table values only)
fuse_text = $(if $(filter file,$(origin $(1))),$(2),as given)
FUSES_BOOT_TEXT = $(if $(filter 0,$(BOOT_BYTES)),no bootloader (reset at 0),$(BOOT_BYTES)-byte boot section at $(BOOT_START_HEX) and reset into it)
FUSES_TEXT_atmega168 = \
  "  lfuse $(LFUSE): $(call fuse_text,LFUSE,external crystal 8-16 MHz (low power)$(comma) slowly rising power$(comma) no /8)" \
  "  hfuse $(HFUSE): $(call fuse_text,HFUSE,brown-out at 2.7 V$(comma) ISP enabled$(comma) RESET kept$(comma) no debugWIRE$(comma) chip erase clears EEPROM)" \
  "  efuse $(EFUSE): $(call fuse_text,EFUSE,$(FUSES_BOOT_TEXT))"
FUSES_TEXT_atmega328p = \
  "  lfuse $(LFUSE): $(call fuse_text,LFUSE,external crystal 8-16 MHz (low power)$(comma) slowly rising power$(comma) no /8)" \
  "  hfuse $(HFUSE): $(call fuse_text,HFUSE,ISP enabled$(comma) RESET kept$(comma) no debugWIRE$(comma) chip erase clears EEPROM$(comma) $(FUSES_BOOT_TEXT))" \
  "  efuse $(EFUSE): $(call fuse_text,EFUSE,brown-out at 2.7 V)"
comma := ,

# ---- checks: before anything is built, one line --------------------------
BOARDS_GOALS := $(filter flash flash-dryrun fuses fuses-dryrun,$(MAKECMDGOALS))
BOARDS_FUSES := $(filter fuses fuses-dryrun,$(MAKECMDGOALS))
ifneq ($(BOARDS_FUSES),)
  ifneq ($(filter $(PROGRAMMER),$(BOOTLOADER_PROGRAMMERS)),)
    $(error PROGRAMMER=$(PROGRAMMER) is a bootloader and cannot write fuses: use an ISP programmer, e.g. make $(firstword $(BOARDS_FUSES)) PROGRAMMER=usbasp (or PROGRAMMER=stk500v1 PORT=... for an Arduino as ISP))
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
.PHONY: flash flash-check flash-dryrun fuses fuses-dryrun flash-room bootloader bootloader-flash sim-board

flash: $(if $(PRINT),,firmware flash-check $(if $(filter-out $(BOOTLOADER_PROGRAMMERS),$(PROGRAMMER)),$(BOOTLOADER_HEX))) ## put the firmware on a board with avrdude: PORT=/dev/ttyUSB0 (or PROGRAMMER=usbasp)
	$(if $(PRINT),@echo '$(FLASH_CMD)',$(FLASH_CMD))

# A board flashed for another clock or baud talks garbage, and another MCU's
# code does not run: the ELF's identity (firmware/build_id.c) must be the
# one asked for, and the .hex must be that ELF's (not one left from an
# earlier build).
flash-check: ## refuse to flash an ELF built for another MCU, F_CPU or BAUD, or a .hex that is not its own (part of make flash)
ifneq ($(filter command line environment,$(origin FLASH_HEX)),)
	@echo "flash-check: FLASH_HEX=$(FLASH_HEX) given: a .hex carries no build identity, not checked (give FLASH_ELF= to check one)"
else
	@id=$$($(AVR_OBJCOPY) -O binary --only-section=.imu_build $(FLASH_ELF) /dev/stdout 2>/dev/null | tr -d '\000'); \
	want="mcu=$(MCU) f_cpu=$(F_CPU)UL baud=$(BAUD)UL"; \
	case "$$id " in *" $$want "*) ;; \
	  *) echo "boards.mk: $(FLASH_ELF) was built as \"$${id:-no build identity}\", not for $$want: nothing flashed (make MCU=... F_CPU=... BAUD=... builds for the board)" >&2; exit 1;; \
	esac; \
	$(AVR_OBJCOPY) -O ihex -j .text -j .data $(FLASH_ELF) $(FLASH_HEX).check && cmp -s $(FLASH_HEX).check $(FLASH_HEX); \
	rc=$$?; rm -f $(FLASH_HEX).check; \
	if [ $$rc -ne 0 ]; then echo "boards.mk: $(FLASH_HEX) is not the image of $(FLASH_ELF): nothing flashed (make rebuilds both)" >&2; exit 1; fi; \
	echo "flash-check: $(FLASH_ELF) is for $$want"
endif

# The bootloader alone onto a chip, through ISP (erases the chip).
bootloader-flash: bootloader ## put the bootloader on a chip through ISP (PROGRAMMER=... CONFIRM=yes; erases it)
	@if [ "$(CONFIRM)" != yes ]; then echo '$(AVRDUDE_CMD) -U flash:w:$(BOOTLOADER_HEX):i'; \
	  echo "boards.mk: nothing written: this erases the chip (firmware, and EEPROM unless EESAVE); then: make bootloader-flash PROGRAMMER=$(PROGRAMMER) CONFIRM=yes, and make fuses" >&2; exit 1; fi
	$(AVRDUDE_CMD) -U flash:w:$(BOOTLOADER_HEX):i

# ---- the simulated board ------------------------------------------------------
# The ATmega168 (or MCU=...) as it leaves the factory with optiboot: flash
# and EEPROM kept in $(SIM_BOARD).flash/.eeprom, the port on
# $(SIM_BOARD_LINK), reset when the port is opened, the synthetic IMU on its
# ADC.  BOOTLOADER=none: no bootloader, the firmware written as by ISP.
# imu-sim --help (Board mode) tells the rest.
SIM_BOARD ?= $(BUILD)/board-$(MCU)
SIM_BOARD_LINK ?= $(BUILD)/imu-board
SIM_BOARD_OPTS ?= --synthetic

sim-board: $(IMU_SIM) $(if $(BOOTLOADER_HEX),$(BOOTLOADER_HEX),firmware) ## the simulated board with optiboot on build/imu-board, for make flash
	@echo "sim-board: the simulated $(MCU) with $(if $(BOOTLOADER_HEX),$(BOOTLOADER_HEX),no bootloader) is on $(SIM_BOARD_LINK) (Ctrl-C here ends it);"
	@echo "its flash and EEPROM are kept in $(SIM_BOARD).flash and .eeprom. In another shell:"
	@echo "    $(if $(BOOTLOADER_HEX),make flash PORT=$(SIM_BOARD_LINK),(no bootloader: the firmware was written as by ISP; make flash needs one))"
	@echo "    picocom -b $(BAUD) $(SIM_BOARD_LINK)"
	$(IMU_SIM) --pty --board $(SIM_BOARD) --mcu $(MCU) --freq $(F_CPU) \
	  --bootloader $(or $(BOOTLOADER_HEX),none)$(if $(BOOTLOADER_HEX),, --flash $(HEX)) \
	  --link $(SIM_BOARD_LINK) $(SIM_BOARD_OPTS)

flash-dryrun: ## print make flash's avrdude command, run nothing
	@echo '$(FLASH_CMD)'

fuses fuses-dryrun: ## set the board's fuses through ISP (CONFIRM=yes); fuses-dryrun prints the command
	@echo "fuses for $(MCU) at F_CPU=$(F_CPU) on a 3.3 V board (see boards.mk):"
	@for l in $(FUSES_TEXT_$(MCU)); do echo "$$l"; done
	@if [ -n "$(PRINT)" ] || [ "$@" = fuses-dryrun ]; then echo '$(FUSES_CMD)'; exit 0; fi; \
	if [ "$(CONFIRM)" != yes ]; then \
	  echo '$(FUSES_CMD)'; \
	  echo "boards.mk: nothing written: wrong fuses can lock a chip out (a wrong clock setting needs an external clock or a high-voltage programmer to recover); check the values above, then: make fuses PROGRAMMER=$(PROGRAMMER)$(if $(PORT), PORT=$(PORT))$(if $(filter-out optiboot,$(BOOTLOADER)), BOOTLOADER=$(BOOTLOADER)) CONFIRM=yes" >&2; \
	  exit 1; \
	fi; \
	echo '$(FUSES_CMD)'; $(FUSES_CMD)

.DEFAULT_GOAL := $(BOARDS_MK_DEFAULT_GOAL)
