/*
 * fuzz_line_state.h - forced into every source of fuzz_line (-include):
 * the firmware's and the fakes' globals go to sections of their own, whose
 * power-up image the fuzzer puts back before each input (fuzz_line.c ends
 * the pragma before its own state).
 */
#pragma clang section bss = "fwstate_bss" data = "fwstate_data"
