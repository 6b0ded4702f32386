/*
 * sim_cli.h - imu-sim's command line: --help and the options.
 */
#ifndef SIM_CLI_H
#define SIM_CLI_H

#include "harness.h"

void parse_args(harness_t *h, int argc, char **argv);

#endif /* SIM_CLI_H */
