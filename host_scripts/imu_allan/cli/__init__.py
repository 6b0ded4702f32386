"""The ``imu-allan`` command line (the entry point is main.main).

main.py   the commands: each reads with device/ or sources/, computes with stats/ or
          analysis/, prints with render/; error handling and exit statuses
args.py   the parser: every word, option and --help text (no numpy: --help starts fast)
study.py  the sweep and thermal commands (the thesis' open questions)
monitor.py  the monitor loop: a port (device/link.py) wired to its view (render/screen.py)
"""
