//! Simulation kernels: PIX2NVS and the DVS emulator (SPEC §4).
