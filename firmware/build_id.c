/*
 * build_id.c - the build's identity (MCU, clock, baud, version) kept in the
 * ELF but outside flash (section .imu_build, placed by the Makefile away
 * from .data, and not part of the .hex): `make flash` reads it and refuses
 * an ELF built for another chip, clock or baud rate than the one asked for.
 */
#include "config.h"

const char build_id[] __attribute__((section(".imu_build"), used)) =
    "imu-allan mcu=" FW_MCU_NAME " f_cpu=" CONFIG_STR(F_CPU) " baud=" CONFIG_STR(BAUD) " version=" FW_VERSION;
