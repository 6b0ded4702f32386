"""The words of the synthetic generator (gen.py): its kinds, profiles, parameters
with their units and help texts.  numpy-free, so that the ``imu-allan`` parser and
its --help name them without importing numpy; gen.py uses them from here."""

from __future__ import annotations

KINDS = ("noise", "walk", "drift", "clip", "square")
PROFILES = ("thesis",)  # gen --profile (analyze's are in profiles.py)
PARAMS = ("offset", "white", "gm_sigma", "gm_tau", "rrw", "drift", "flicker")
UNITS = {
    "offset": "counts",
    "white": "counts per sample (sigma)",
    "gm_sigma": "counts (sigma)",
    "gm_tau": "s",
    "rrw": "counts per sample (sigma of each step)",
    "drift": "counts/s",
    "flicker": "counts (IEEE 952 bias instability B)",
}
HELP = {
    "offset": "mean code, counts",
    "white": "white noise sigma per sample, counts (N = white / sqrt(fs))",
    "gm_sigma": "Gauss-Markov bias instability sigma, counts",
    "gm_tau": "Gauss-Markov correlation time T, seconds",
    "rrw": "rate random walk: sigma of each step, counts (K = rrw * sqrt(fs))",
    "drift": "linear drift, counts per second",
    "flicker": "flicker (1/f) bias instability B, counts (Allan deviation floor 0.664 B)",
}
